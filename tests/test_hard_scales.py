"""Hard-case family 5 (examples/hard_cases.py): extreme scales. R from 1 mm to 5 m, M from 1 g to
1 t, g from 1e-3 to 100 m/s^2, inertia at the limits of physical bodies (ring, thin disc). Physics,
not just "no exception": M drops out, dynamic similarity in tau = t sqrt(g / R), energy conserved,
and errors relative to the wheel's own scales (R, sqrt(g/R), M g R) stay the same at every scale
(the nominals of the absolute tolerances)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy import simulate_fmu

from conftest import STATES
from fmi_helpers import Slave
from gyrowheel.fmu_build import build_fmu, parse_scene

SCENE = """
[model]
name = "hard_scales"
# [wheel]: the defaults, the paper wheel (M 2 kg, R 0.17 m, k 0.25 / 0.4, beta_min 0.02)
[effects.gravity]
g = 9.81
"""
W0 = math.sqrt(9.81 / 0.17)  # the paper wheel's rate scale
TAU = 10.0                   # dimensionless horizon, ~ 1.3 s of the paper wheel
SCALES = [(0.17, 9.81), (1e-3, 9.81), (5.0, 9.81), (0.17, 1e-3), (0.17, 100.0), (1e-3, 100.0), (5.0, 1e-3)]


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    root = tmp_path_factory.mktemp("hard_scales")
    # every run names dopri5 or dop853 (Co-Simulation) or is CVode's (Model Exchange): no Taylor kernel
    return str(build_fmu(parse_scene(SCENE, "hard_scales.toml"), root / "hard_scales.fmu", taylor=False).fmu)


def _dimensionless(R, g, M=2.0, solver=5, rel_tol=1e-11, abs_tol=1e-13, tau=TAU, **extra):
    """The paper start (80 deg, gamma_dot = 6 rad/s at the paper scale) mapped to (R, g), run to tau;
    returns the final state in units of R (x, y), 1 (angles), sqrt(g/R) (rates), and energies / (M g R)."""
    w = math.sqrt(g / R)
    return dict(M=M, R=R, g=g, gamma_dot=6.0 * w / W0, solver=solver, rel_tol=rel_tol, abs_tol=abs_tol,
                max_step=100.0 / w, **extra), tau / w, np.array([R, R, 1, 1, 1, w, w, w])


def _run(fmu, R, g, M=2.0, **kw):
    start, stop, unit = _dimensionless(R, g, M, **kw)
    s = Slave(fmu)
    try:
        s.init(**start)
        e0 = s.get("energy")
        energies = [e0]
        for i in range(10):
            s.slave.doStep(stop * i / 10, stop / 10)
            energies.append(s.get("energy"))
        x = np.array(s.get(*STATES))
    finally:
        s.free()
    return x / unit, (np.array(energies) - e0) / (M * g * R), x


def test_mass_drops_out(fmu):
    """M = 1 g, 2 kg, 1 t: the same trajectory to 1e-10 relative, energy proportional to M."""
    _, _, base = _run(fmu, 0.17, 9.81, M=2.0)
    for M in (1e-3, 1e3):
        _, de, x = _run(fmu, 0.17, 9.81, M=M)
        np.testing.assert_allclose(x, base, rtol=1e-10, atol=1e-12)
        assert np.max(np.abs(de)) < 1e-10


@pytest.mark.parametrize("R,g", SCALES[1:])
def test_dynamic_similarity(fmu, R, g):
    """With t in units of sqrt(R/g), lengths in R and rates in sqrt(g/R) the motion is the same at
    every scale: R 1 mm ... 5 m, g 1e-3 ... 100 m/s^2 (time scales 3 ms ... 70 s)."""
    base, _, _ = _run(fmu, 0.17, 9.81)
    scaled, de, _ = _run(fmu, R, g)
    err = np.abs(scaled - base) / np.maximum(1.0, np.abs(base))
    assert np.max(err) < 1e-9, dict(zip(STATES, err))
    assert np.max(np.abs(de)) < 1e-10


@pytest.mark.parametrize("R,g", [(1e-3, 100.0), (5.0, 1e-3), (1e-3, 1e-3), (5.0, 100.0)])
@pytest.mark.parametrize("k_diam,k_axial", [(0.5, 1.0), (0.25, 0.5), (0.01, 0.02), (0.3, 0.45)])
def test_energy_conserved_at_the_extremes(fmu, R, g, k_diam, k_axial):
    """Ring (k_axial = 1), uniform and point-like thin discs (k_axial = 2 k_diam), a thick wheel,
    at the corner scales: |E - E0| / (M g R) < 1e-9 over tau = 10."""
    scaled, de, _ = _run(fmu, R, g, M=1e-3 if R < 1 else 1e3, k_diam=k_diam, k_axial=k_axial)
    assert np.all(np.isfinite(scaled))
    assert np.max(np.abs(de)) < 1e-9


@pytest.fixture(scope="module")
def tolerance_errors(fmu):
    """Dimensionless error of a loose run (abs_tol dominant: rel_tol 1e-12, abs_tol 1e-7, DOPRI5)
    against a tight DOP853 run at the same scale, for every scale."""
    out = {}
    for R, g in SCALES:
        loose, _, _ = _run(fmu, R, g, solver=3, rel_tol=1e-12, abs_tol=1e-7)
        tight, _, _ = _run(fmu, R, g, solver=5, rel_tol=1e-13, abs_tol=1e-15)
        out[(R, g)] = float(np.max(np.abs(loose - tight) / np.maximum(1.0, np.abs(tight))))
    return out


def test_tolerances_scale_with_the_wheel(tolerance_errors):
    """abs_tol is relative to the nominals (R, sqrt(g/R)): the error in the wheel's own units is the
    same at every scale (within a factor 10) and small. With fixed nominals the 5 m wheel on
    g = 1e-3 (rates ~ 0.014 rad/s) would get a 70x looser tolerance than the paper wheel."""
    errors = tolerance_errors
    print("dimensionless errors:", {k: f"{v:.1e}" for k, v in errors.items()})
    assert max(errors.values()) < 1e-5
    assert max(errors.values()) < 10 * min(errors.values())


def test_model_exchange_with_cvode_at_a_millimetre_wheel(fmu):
    """fmpy's CVode drives the FMU as Model Exchange at R = 1 mm, g = 100 (time scale 3 ms):
    the same dimensionless end state as Co-Simulation."""
    start, stop, unit = _dimensionless(1e-3, 100.0)
    cs, _, _ = _run(fmu, 1e-3, 100.0)
    values = {k: v for k, v in start.items() if k in ("M", "R", "g", "gamma_dot")}
    r = simulate_fmu(fmu, fmi_type="ModelExchange", solver="CVode", stop_time=stop, output_interval=stop / 100,
                     relative_tolerance=1e-10, start_values=values)
    assert r["time"][-1] == pytest.approx(stop, rel=1e-12)
    me = np.array([r[n][-1] for n in STATES]) / unit
    err = np.abs(me - cs) / np.maximum(1.0, np.abs(cs))
    assert np.max(err) < 1e-6, dict(zip(STATES, err))
    e = r["energy"]
    assert np.ptp(e) / (2.0 * 100.0 * 1e-3) < 1e-6
