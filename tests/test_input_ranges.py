"""The valid ranges of the wheel's radius, gravity, start rates and effect coefficients.

Each range (model/spec.py: RADIUS_RANGE, GRAVITY_RANGE, RATE_RANGE, K_DIAM_MAX, COEFFICIENT_MAX)
is refused beyond where it is read (`gyrowheel simulate --set`: exit 2, one line naming the field
and the range, nothing written; the scene reader alike, tests/test_extreme_inputs.py) and runs at its ends, in the rolling-only
FMU (paper_earth) and the contact one (drop_bounce: flight, impacts, sliding). Beyond them the
runtime failed: R = 1e-300 m and g = 1e300 m/s2 gave NaN in the touchdown's update, gamma_dot =
1e150 rad/s and g = 1e20 m/s2 "step size underflow". The FMU's modelDescription.xml declares the
same bounds as min/max (FMI 2.0.4 section 2.2.7): just inside runs, just outside is refused.
Positions and angles have no range: x = 1e300 m runs, its motion below the double spacing.
"""
from __future__ import annotations

import math

import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

import gyrowheel
from gyrowheel.errors import ArgumentError
from gyrowheel.simulation import SimulationError

RIM = "R must be <= c = 299792458 m/s (Newtonian mechanics: a rim point below the speed of light)"
NOTE = "(the wheel's time scales, sqrt(R/g) >= 1 us and 1/|rate| >= 1 ns, above the solvers' step-size floor)"


@pytest.fixture(scope="module")
def drop(example_build):
    return str(example_build("drop_bounce").fmu)


@pytest.fixture(scope="module")
def earth(earth_fmu):
    return str(earth_fmu)


def _simulate(fmu, tmp_path, *sets, stop="0.05"):
    out = tmp_path / "out.csv"
    args = [a for s in sets for a in ("--set", s)]
    r = subprocess.run([sys.executable, "-m", "gyrowheel", "simulate", fmu, "--stop-time", stop, *args,
                        "-o", str(out)], capture_output=True, text=True)
    return r, out


REFUSED = [
    ("gamma_dot=1e150", f"gamma_dot must lie in [-1e+09, 1e+09] rad/s {NOTE}"),
    ("alpha_dot=-1e20", f"alpha_dot must lie in [-1e+09, 1e+09] rad/s {NOTE}"),
    ("beta_dot=1.000001e9", f"beta_dot must lie in [-1e+09, 1e+09] rad/s {NOTE}"),
    ("R=1e-300", f"R must lie in [1e-06, 1e+06] m {NOTE}"),
    ("R=1e20", f"R must lie in [1e-06, 1e+06] m {NOTE}"),
    ("g=1e300", "g must be <= 1e+06"),
    ("g=1e20", "g must be <= 1e+06"),
    ("k_diam=1e300", "k_diam must be <= 1e+06"),
    # a combination: each value named with its source
    ("R=1e6 gamma_dot=300", f"|gamma_dot (300, given)| R (1000000, given){RIM[1:]}"),
    ("R=1 alpha_dot=-299792458.000001", f"|alpha_dot (-299792458.000001, given)| R (1, given){RIM[1:]}"),
]


@pytest.mark.parametrize("fmu_name", ["earth", "drop"])
@pytest.mark.parametrize("value, reason", REFUSED)
def test_set_beyond_a_range_exits_2_naming_field_and_range(request, fmu_name, tmp_path, value, reason):
    r, out = _simulate(request.getfixturevalue(fmu_name), tmp_path, *value.split())
    assert r.returncode == 2, r.stderr
    assert r.stderr == f"gyrowheel: error: --set: the FMU refused the start values: {reason}\n"
    assert not out.exists()


def _finite(result):
    return all(np.isfinite(result[k]).all() for k in result.dtype.names if result[k].dtype.kind == "f")


@pytest.mark.parametrize("fmu_name", ["earth", "drop"])
@pytest.mark.parametrize("values", [
    {"M": 1e-30, "R": 1e-6, "g": 1e6, "gamma_dot": 1e9},
    {"M": 1e30, "R": 1e6, "g": 1e6, "gamma_dot": -299.79},
    {"M": 1e-30, "R": 0.1, "g": 1e6, "gamma_dot": 1e9},
    {"M": 1e30, "R": 1e-6, "g": 0.0, "alpha_dot": 1e9, "beta_dot": -1e9},
])
def test_the_ranges_ends_run_finite_or_stop_on_the_budget(request, fmu_name, values):
    """At the ends of the ranges a run is finite; one that 1e9 rad/s makes too long for the step
    budget stops with the budget's message (how many steps it would need), never NaN or "step size
    underflow"."""
    try:
        result = gyrowheel.simulate(request.getfixturevalue(fmu_name), stop_time=0.002, start_values=values)
    except SimulationError as exc:
        assert "would need about" in str(exc) and "nan" not in str(exc).lower(), str(exc)
    else:
        assert len(result) >= 2 and _finite(result)


def test_far_positions_run_and_leave_the_motion_unchanged(earth):
    """The equations do not depend on x, y (the ground is uniform): far away the rates follow
    the run at the origin, to the solver's tolerance."""
    near = gyrowheel.simulate(earth, stop_time=0.2)
    far = gyrowheel.simulate(earth, stop_time=0.2, start_values={"x": 1e300, "y": -1e300})
    assert _finite(far) and far["x"][-1] == 1e300 and far["y"][-1] == -1e300
    for name in ("beta", "alpha_dot", "beta_dot", "gamma_dot"):
        assert np.allclose(far[name], near[name], rtol=1e-6, atol=1e-6), name


def _bounds(fmu):
    with zipfile.ZipFile(fmu) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    bounds = {}
    for sv in root.iter("ScalarVariable"):
        element = sv[0]
        if "min" in element.attrib or "max" in element.attrib:
            bounds[sv.get("name")] = (element.get("min"), element.get("max"), element.tag)
    return bounds


def _next(value: float, direction: float) -> float:
    return float(np.nextafter(value, direction))


def test_declared_min_max_are_the_runtimes_refusal_bounds(drop):
    """Every min/max in modelDescription.xml: the bound itself runs, the next double beyond is
    refused before the run (ArgumentError naming start_values)."""
    bounds = _bounds(drop)
    assert {"M", "R", "k_diam", "g", "mu", "restitution", "rel_tol", "abs_tol", "max_internal_steps"} <= set(bounds)
    assert bounds["R"][:2] == ("1e-06", "1000000.0") and bounds["M"][:2] == ("1e-30", "1e+30")
    for name, (low, high, tag) in bounds.items():
        for text, direction in ((low, -np.inf), (high, np.inf)):
            if text is None:
                continue
            edge = float(text)
            if name == "abs_tol" and direction < 0 or name == "restitution" and direction > 0:
                inside = {name: edge}  # abs_tol 0: follow rel_tol; restitution 1: elastic
            else:
                inside = {name: int(edge) if tag == "Integer" else edge}
            if name in ("mu",) and direction < 0:
                inside["mu_k"] = 0.0  # mu_k <= mu
            # a run at 10 machine epsilons takes minutes, one internal step per call cannot cross an
            # output interval: both are accepted as start values, only the refusal beyond is run
            if not (direction < 0 and name in ("rel_tol", "max_internal_steps")):
                gyrowheel.simulate(drop, stop_time=0.001, start_values=inside)
            beyond = dict(inside)
            beyond[name] = (int(edge) + (1 if direction > 0 else -1)) if tag == "Integer" else _next(edge, direction)
            if name == "abs_tol" and direction < 0:
                beyond[name] = -5e-324
            with pytest.raises(ArgumentError, match=f"start_values: .*{name}"):
                gyrowheel.simulate(drop, stop_time=0.001, start_values=beyond)


@pytest.mark.parametrize("route", ["rel_tol", "tolerance"])
def test_the_printed_lower_bound_of_the_tolerance_is_accepted(drop, route):
    """The refusal of a tolerance below 10 eps prints the bound with every digit: typed back (as
    the start value rel_tol, or as fmi2SetupExperiment's tolerance), it runs."""
    from fmpy import simulate_fmu
    below = 2.22e-15  # the bound rounded to 3 digits: below 10 eps = 2.2204460492503131e-15
    with pytest.raises(Exception) as exc:
        if route == "rel_tol":
            gyrowheel.simulate(drop, stop_time=1e-4, start_values={"rel_tol": below})
        else:
            simulate_fmu(str(drop), stop_time=1e-4, relative_tolerance=below)
    if route == "rel_tol":
        printed = str(exc.value).split("valid range [")[1].split(",")[0]
        assert float(printed) == 10 * np.finfo(float).eps
        gyrowheel.simulate(drop, stop_time=1e-4, start_values={"rel_tol": float(printed)})
    else:
        simulate_fmu(str(drop), stop_time=1e-4, relative_tolerance=2.2204460492503131e-15)


def test_fmpy_validates_the_fmu_with_its_ranges(drop):
    from fmpy.validation import validate_fmu
    assert validate_fmu(drop) == []


@pytest.fixture(scope="module")
def drag(tmp_path_factory):
    """A scene with air drag, the default build (solver auto: taylor, the kernel built in)."""
    tmp = tmp_path_factory.mktemp("drag")
    scene = tmp / "drag.toml"
    scene.write_text('[model]\nname = "drag"\n[effects.gravity]\n[effects.air_drag]\n')
    return gyrowheel.build(scene, output=tmp / "drag.fmu").fmu


@pytest.mark.parametrize("solver", ["dop853", "dopri5"])
def test_a_combination_too_stiff_for_an_explicit_solver_says_why(drag, solver):
    """In range one by one, a 1e-30 kg wheel with linear drag c_lin = 1e6 N s/m relaxes its speed
    in M (1 + k_axial) / c_lin = 1.4e-36 s, far below the step-size floor: an explicit solver stops
    with its step size underflow, named, and the message says what it means and what may work
    (rosenbrock: the next test), naming the ranges' documentation (exit 1: a run that failed, not
    a value out of range)."""
    with pytest.raises(SimulationError) as exc:
        gyrowheel.simulate(drag, stop_time=0.01, start_values={"M": 1e-30, "c_lin": 1e6, "solver": solver})
    text = str(exc.value)
    assert "step size underflow" in text and f"solver {solver})" in text and "\n" not in text
    assert text.endswith("the model's fastest time scale is shorter than the solver's smallest step, 16 eps "
                         "max(|t|, 1) s: an explicit solver cannot follow values this stiff (e.g. strong damping "
                         "on a light wheel); solver rosenbrock (implicit, L-stable) may (docs/interface.md, "
                         "\"Valid ranges\")")


def test_rosenbrock_integrates_the_combination_too_stiff_for_explicit_solvers(drag):
    """The same 1e-30 kg wheel with c_lin = 1e6 N s/m under rosenbrock (L-stable): 20 s run; the
    drag stops the rolling at once (gamma_dot below 1e-12 rad/s) and the wheel keeps only its
    potential energy M g z_c, z_c = R sin(beta) the centre's height (energy to 1e-9 relative)."""
    result = gyrowheel.simulate(drag, stop_time=20.0, start_values={"M": 1e-30, "c_lin": 1e6, "solver": "rosenbrock"})
    assert result["time"][-1] == 20.0 and abs(result["gamma_dot"][-1]) < 1e-12
    info = gyrowheel.info(drag)
    R, g = (info.variable(n).start for n in ("R", "g"))
    assert result["energy"][-1] == pytest.approx(1e-30 * g * R * math.sin(result["beta"][-1]), rel=1e-9)
    assert result["energy"][-1] < result["energy"][0]


def test_a_combination_too_stiff_for_the_taylor_series_names_its_time_scale(drag):
    """The same combination under the default solver auto (taylor here): the series overflows at
    the first step; the message gives the solution's time scale from the finite orders, the drag's
    relaxation time M (1 + k_axial) / c_lin = 1.4e-36 s (the rolling wheel's spin slows with its
    speed: its effective mass is M (1 + k_axial), k_axial = 0.4), says it is below the smallest
    step and what may work.  A model whose series diverges for another reason keeps the
    singularity wording (tests/test_taylor_near_pole.py)."""
    with pytest.raises(SimulationError) as exc:
        gyrowheel.simulate(drag, stop_time=0.01, start_values={"M": 1e-30, "c_lin": 1e6})
    text = str(exc.value)
    assert "\n" not in text and "Taylor coefficients of order" in text
    scale = float(text.split("time scale, ")[1].split(" s from")[0])
    assert scale == pytest.approx(1.4e-30 * 1e-6, rel=0.04)
    assert text.endswith("is below the smallest step, 16 eps max(|t|, 1) s (too stiff for an explicit method); "
                         "values this stiff (e.g. strong damping on a light wheel) need an implicit solver: solver "
                         "rosenbrock (L-stable) may integrate them (docs/interface.md, \"Valid ranges\")")


def test_an_ensemble_lane_too_stiff_names_its_time_scale(drag, tmp_path):
    """The ensemble's lanes keep their series in the batch's block: the message of a lane that
    is too stiff reads that lane's series (1.4e-36 s), while the lane beside it (the nominal
    2 kg wheel, c_lin = 0.1 N s/m) runs to the end.  It ends with what may work instead: the
    ensemble runs only solver taylor, so the FMU with rosenbrock."""
    from gyrowheel.taylor.ensemble import STATUS_ERROR, STATUS_OK, Ensemble
    result = Ensemble(drag, lanes=2, cache=tmp_path).run(0.01, parameters={"M": [1e-30, 2.0], "c_lin": [1e6, 0.1]})
    assert list(result.status) == [STATUS_ERROR, STATUS_OK]
    (message,) = [m for m in result.messages if m.startswith("ensemble trajectory 0")]
    assert "time scale, 1.4e-36 s from the finite orders, is below the smallest step" in message
    assert message.endswith("(too stiff for an explicit method); values this stiff (e.g. strong damping on a "
                            "light wheel) need an implicit solver: simulate the FMU with solver rosenbrock "
                            "(L-stable), or sweep it with --solver rosenbrock (the ensemble runs "
                            "solver taylor only; docs/interface.md, \"Valid ranges\")"), message


def test_fmi3_declares_the_same_bounds(earth, fmi3_earth_fmu):
    """FMI 3.0 (<Float64 min max>, <Int32 min max>) declares the bounds of the FMI 2.0 twin."""
    from fmpy.validation import validate_fmu
    with zipfile.ZipFile(fmi3_earth_fmu) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    bounds3 = {v.get("name"): (v.get("min"), v.get("max")) for v in root.find("ModelVariables")
               if "min" in v.attrib or "max" in v.attrib}
    assert bounds3 == {name: (low, high) for name, (low, high, _) in _bounds(earth).items()}
    assert validate_fmu(str(fmi3_earth_fmu)) == []


@pytest.mark.parametrize("value", ["1e10", "10000000000", "-3000000000", "2147483648"])
def test_an_integer_outside_its_32_bits_is_out_of_range_naming_the_variables_range(earth, fmi3_earth_fmu, tmp_path,
                                                                                   value):
    """max_internal_steps (an fmi2Integer, an fmi3Int32: 32 bits) given a whole number outside
    them: one line naming the range the FMU declares for it (min, max of modelDescription.xml,
    [1, 2^31 - 1]), exit 2, nothing written; not "not a valid Integer", which a whole number is."""
    for fmu, fmi_type in ((earth, "Integer"), (str(fmi3_earth_fmu), "Int32")):
        low, high = _bounds(earth)["max_internal_steps"][:2] if fmi_type == "Integer" else ("1", str(2**31 - 1))
        r, out = _simulate(fmu, tmp_path, f"max_internal_steps={value}")
        assert r.returncode == 2 and not out.exists(), r.stderr
        assert r.stderr == (f"gyrowheel: error: --set: value '{value}' for 'max_internal_steps' is out of range "
                            f"[{low}, {high}] ({fmi_type})\n")
        with pytest.raises(ArgumentError) as exc:
            gyrowheel.simulate(fmu, stop_time=0.05, start_values={"max_internal_steps": int(float(value))})
        assert exc.value.argument == "start_values" and str(exc.value) == (
            f"start_values: value '{int(float(value))}' for 'max_internal_steps' is out of range "
            f"[{low}, {high}] ({fmi_type})")
    assert (low, high) == ("1", "2147483647")


def test_a_whole_number_in_any_notation_is_an_integer(earth):
    """'1e3' and 1000.0 are the whole number 1000 (a fraction, 1.5, is refused: tests/test_cli.py;
    the range's ends: test_declared_min_max_are_the_runtimes_refusal_bounds)."""
    from gyrowheel.simulation import check_start_values
    for value in ("1e3", 1000.0, "1000", " 1000 "):
        typed = check_start_values(earth, {"max_internal_steps": value})["max_internal_steps"]
        assert typed == 1000 and type(typed) is int
    assert len(gyrowheel.simulate(earth, stop_time=0.05, start_values={"max_internal_steps": "1e3"})) == 6
