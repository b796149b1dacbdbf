"""Extreme values of the contact scenes: refused where they are read, naming the field, the range
and its reason (exit 2, nothing written), or run.

Physical ranges (model/spec.py): the start speeds of the contact modes (vz, slip_long, slip_lat)
below the speed of light, the wheel's mass M in [1e-30, 1e30] kg, its radius, start rates (and
their rim speed) and the effects' coefficients (tests/test_input_ranges.py runs them); the scene
reader and the FMU's checks at initialisation (`gyrowheel simulate --set`) refuse others alike. Tolerances: every
abs_tol of the documented range [1e-30, 1] runs (the first step of an adaptive solver is at least
1000 step-size floors, whatever abs_tol); the run agrees with the default tolerance's to rounding.
"""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from gyrowheel.fmu_build.scene import SceneError, parse_scene

C = "c = 299792458 m/s (Newtonian mechanics: below the speed of light)"
MASS = "M (mass) must lie in [1e-30, 1e+30] kg (beyond, the contact's products of masses and squared speeds " \
       "leave double precision)"
TIME_SCALES = "(the wheel's time scales, sqrt(R/g) >= 1 us and 1/|rate| >= 1 ns, above the solvers' step-size floor)"
FLY = '[model]\nname = "x"\n[effects.gravity]\n[effects.contact_forces]\non_slip = "slide"\non_lift_off = "fly"\n'


@pytest.fixture(scope="module")
def drop(example_build):
    return str(example_build("drop_bounce").fmu)


def _simulate(fmu, tmp_path, *sets):
    out = tmp_path / "out.csv"
    args = [a for s in sets for a in ("--set", s)]
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "simulate", fmu, *args, "-o", str(out)],
                       capture_output=True, text=True)
    return r, out


@pytest.mark.parametrize("value, reason", [
    ("vz=1e150", f"vz must lie in [-c, c], {C}"),
    ("M=1e150", MASS),
    ("M=1e-300", MASS),
    ("slip_long=1e308", f"slip_long must lie in [-c, c], {C}"),
    ("slip_lat=-3e8", f"slip_lat must lie in [-c, c], {C}"),
])
def test_set_outside_the_physical_range_is_refused_naming_it(drop, tmp_path, value, reason):
    r, out = _simulate(drop, tmp_path, value, "height=0.1") if value.startswith("vz") else \
        _simulate(drop, tmp_path, value)
    assert r.returncode == 2, r.stderr
    assert r.stderr == f"gyrowheel: error: --set: the FMU refused the start values: {reason}\n"
    assert not out.exists()


@pytest.mark.parametrize("table, line, message", [
    ("initial", "height = 0.1\nvz = 1e150", f"[initial] vz: must lie in [-c, c], {C}, got 1e+150"),
    ("initial", "slip_long = 1e308", f"[initial] slip_long: must lie in [-c, c], {C}, got 1e+308"),
    ("wheel", "M = 1e150", "[wheel] M: must lie in [1e-30, 1e+30] kg (beyond, the contact's products of masses "
                           "and squared speeds leave double precision), got 1e+150"),
    ("wheel", "M = 1e-300", "[wheel] M: must lie in [1e-30, 1e+30] kg"),
    ("wheel", "R = 1e-300", f"[wheel] R: must lie in [1e-06, 1e+06] m {TIME_SCALES}, got 1e-300"),
    ("initial", "gamma_dot = 1e150", f"[initial] gamma_dot: must lie in [-1e+09, 1e+09] rad/s {TIME_SCALES}, "
                                     "got 1e+150"),
    ("initial", "gamma_dot = 1e9\n[wheel]\nR = 1.0", "[initial] gamma_dot: |gamma_dot| R must be <= c = 299792458 "
     "m/s (Newtonian mechanics: a rim point below the speed of light), got 1000000000.0 with R = 1.0"),
    ("effects.air_drag", "rho_air = 1e300", "[effects.air_drag] rho_air: must be <= 1e+06, got 1e+300"),
])
def test_scene_outside_the_physical_range_is_refused_naming_it(table, line, message):
    with pytest.raises(SceneError) as err:
        parse_scene(FLY + f"[{table}]\n{line}\n", "s.toml")
    assert message in str(err.value)


def test_the_range_edges_run(drop, tmp_path):
    """Values just inside: a 2e8 m/s throw and a 1e20 kg wheel run to the stop time."""
    for sets in (("height=0.1", "vz=2e8"), ("M=1e20",), ("M=1e-29",)):
        r, out = _simulate(drop, tmp_path, *sets)
        assert r.returncode == 0, (sets, r.stderr)


@pytest.mark.parametrize("abs_tol", ["1e-25", "1e-30"])
def test_abs_tol_down_to_its_documented_least_runs(drop, tmp_path, abs_tol):
    """abs_tol 1e-25 and 1e-30 (inside [1e-30, 1]), where Hairer's first-step estimate lies below
    the step-size floor, run and give the default tolerance's trajectory to rounding (both
    converged: the drop's flight is a parabola, its landing located)."""
    r, out = _simulate(drop, tmp_path, f"abs_tol={abs_tol}")
    assert r.returncode == 0, r.stderr
    (tmp_path / "ref").mkdir()
    ref_r, ref_out = _simulate(drop, tmp_path / "ref", "abs_tol=0")
    assert ref_r.returncode == 0
    got = np.genfromtxt(out, delimiter=",", names=True)
    ref = np.genfromtxt(ref_out, delimiter=",", names=True)
    for name in ("x", "y", "z", "beta", "energy"):
        assert np.max(np.abs(got[name] - ref[name])) < 1e-8, name
