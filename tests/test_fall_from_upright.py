"""The fall time from (nearly) upright does not depend on max_step (docs/accuracy.md, docs/hard_cases.md).

Near beta = pi/2 the ulp of beta is 2.2e-16: a lean rate of 1e-17 rad/s times a step of 1 ms is an
increment far below half an ulp, which plain x + h k rounds away: the fall from fl(pi/2) would come
at 5.83 s with max_step 0.1 s, 9.06 s with 0.01 s and never (40 s) with 1e-3 s. Every solver adds
its increments with compensated summation (TwoSum: x + xc carries what rounding drops,
c_src/gw_solver.c gw_sum_update), so the increments accumulate whatever the step size.

Reference, independent of the FMU: the wheel started upright without rates stays in the plane
(alpha_dot = gamma_dot = 0 for all time), so energy gives the lean rate in closed form,
(1 + k_diam) R beta_dot^2 / 2 = g (sin beta0 - sin beta), and the time to reach beta_min is the
quadrature T = int du / sqrt(2 c (cos eps - cos u)) over the lean u = pi/2 - beta from
eps = pi/2 - beta0 to pi/2 - beta_min, c = g / (R (1 + k_diam)), evaluated with mpmath at 50
digits (cos eps - cos u written as 2 sin((u+eps)/2) sin((u-eps)/2), exact near the endpoint).

What is left: the right-hand side is still evaluated at the double nearest the state, whose lean
near upright is quantised to 2.2e-16 rad; from fl(pi/2) itself (lean 6.1e-17) that quantisation of
the first e-folds shifts the fall by up to ~0.07 s of 5.67 s. From a lean of 1e-10 rad it is
below 1e-6 s.
"""
from __future__ import annotations

import math

import mpmath as mp
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime

from fmi_helpers import Slave
from gyrowheel.fmu_build import build_fmu, parse_scene

SCENE = """
[model]
name = "upright"
[wheel]
beta_min = 0.02
[effects.gravity]
g = 9.81
"""
M, R, K_DIAM, G, BETA_MIN = 2.0, 0.17, 0.25, 9.81, 0.02


def fall_time_quadrature(beta0: float, beta_end: float = BETA_MIN) -> float:
    """Time from rest at beta0 (a double) to beta_end, by the energy quadrature above."""
    mp.mp.dps = 50
    c = mp.mpf(G) / (mp.mpf(R) * (1 + mp.mpf(K_DIAM)))
    eps = mp.pi / 2 - mp.mpf(beta0)
    umax = mp.pi / 2 - mp.mpf(beta_end)
    points = [eps] + [eps * 10**k for k in range(1, 40) if eps * 10**k < umax] + [umax]
    return float(mp.quad(lambda u: 1 / mp.sqrt(4 * c * mp.sin((u + eps) / 2) * mp.sin((u - eps) / 2)),
                         points))


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    root = tmp_path_factory.mktemp("upright")
    # every run names dop853 or dopri5: no Taylor kernel
    return str(build_fmu(parse_scene(SCENE, "upright.toml"), root / "upright.fmu", taylor=False).fmu)


def fall_time(fmu: str, beta0: float, max_step: float, solver: int = 5) -> float:
    s = Slave(fmu)
    try:
        s.init(solver=solver, beta=beta0, gamma_dot=0.0, rel_tol=1e-12, abs_tol=1e-14, max_step=max_step,
               max_internal_steps=10**7)
        t = 0.0
        while t < 30.0:
            try:
                s.slave.doStep(t, 1.0)
            except FMICallException as exc:
                assert exc.status == 2 and s.get("fallen")
                return s.slave.getRealStatus(fmi2LastSuccessfulTime)
            t += 1.0
        return math.inf
    finally:
        s.free()


def test_quadrature_reference_matches_the_linear_growth():
    """Sanity of the reference: from a lean eps the lean grows like eps cosh(t sqrt(c)), so the time to
    a lean of 1e-3 rad is acosh(1e-3 / eps) / sqrt(c) to O(lean^2)."""
    beta0 = math.pi / 2 - 1e-10
    eps = float(mp.pi / 2 - mp.mpf(beta0))
    sqrt_c = math.sqrt(G / (R * (1 + K_DIAM)))
    linear = math.acosh(1e-3 / eps) / sqrt_c
    assert fall_time_quadrature(beta0, math.pi / 2 - 1e-3) == pytest.approx(linear, rel=1e-6)


@pytest.mark.parametrize("beta0, spread, off", [
    (math.pi / 2 - 1e-10, 1e-6, 1e-6),  # plain summation: the fall off by 7.4e-6 s
    (math.pi / 2, 0.06, 0.08),          # plain summation: 5.83 s / 9.06 s / never, reference 5.669 s
])
def test_fall_time_does_not_depend_on_max_step(fmu, beta0, spread, off):
    ref = fall_time_quadrature(beta0)
    times = [fall_time(fmu, beta0, h) for h in (0.1, 0.01, 1e-3)]
    assert max(times) - min(times) < spread, times
    assert max(abs(t - ref) for t in times) < off, (times, ref)


def test_fall_time_with_dopri5_and_fine_steps(fmu):
    """DOPRI5 too, down to max_step 1e-4 s (40 s never fell before)."""
    ref = fall_time_quadrature(math.pi / 2)
    t = fall_time(fmu, math.pi / 2, 1e-4, solver=3)
    assert abs(t - ref) < 0.08
