"""The ensemble path's results (c_src/gw_ensemble.c, taylor/ensemble.py) against solver
taylor's single runs, and its refusals.

- an ensemble equals N fmi2DoStep runs with taylor, falls included; a job's tail and the lanes'
  refills (N not a multiple of the lanes, trajectories ending at different times) on 1, 4 and 8
  lanes give the same steps;
- the batch's lane-innermost passes give each lane solver taylor's one-lane numbers bit for bit
  (the build with GW_ENSEMBLE_LANE_STEPS=1), with either step size form;
- a bad trajectory is reported with its index, a bad job, value or lane count is a ValueError
  naming the field.
"""
from __future__ import annotations

import re

import numpy as np
import pytest

from c_programs import C_SRC
from conftest import SCENES, STATES
from gyrowheel.errors import ArgumentError, ArgumentTypeError, FmuError, UnknownNameError
from gyrowheel.taylor.ensemble import LANES, STATUS_OK, STATUS_TERMINATED, Ensemble
from gyrowheel.taylor.lanes import ensemble_lanes
from taylor_helpers import TAYLOR, fmu_runner


@pytest.fixture(scope="module")
def paper(example_build):
    built = example_build("paper_earth", taylor=True)
    return built, fmu_runner(built.fmu)


def _one_step_run(runner, stop: float, **values) -> float:
    """Start `runner` with values and run one fmi2DoStep(0, stop): the time reached (stop, or
    fmi2LastSuccessfulTime when the run ended early, a fall)."""
    from fmpy.fmi2 import fmi2LastSuccessfulTime
    runner.start(**values)
    try:
        runner.slave.doStep(0.0, stop)
        return stop
    except Exception:
        return runner.slave.getRealStatus(fmi2LastSuccessfulTime)


def test_ensemble_equals_single_runs(paper, tmp_path):
    """N trajectories (g, gamma_dot varied; some fall) equal N fmi2DoStep runs with taylor, on the
    default lanes (the machine's, gyrowheel.taylor.lanes.ensemble_lanes: the library reports the
    GW_ENSEMBLE_LANES it was built with, so the default reaches the C; the sweep engine uses it)."""
    built, runner = paper
    ens = Ensemble(built.fmu, cache=tmp_path)
    assert LANES is None and ens.lanes == ensemble_lanes(built.fmu, tmp_path)
    g = np.array([9.81, 3.721, 1.625, 9.81, 9.81, 0.0, 9.81, 5.0, 9.81, 2.0])
    spin = np.array([6.0, 6.0, 6.0, 1.0, 0.5, 3.0, 8.0, 4.0, 0.2, 6.0])
    res = ens.run(20.0, parameters={"g": g, "beta_min": 0.1}, starts={"gamma_dot": spin}, rel_tol=1e-10)
    assert set(res.status) <= {STATUS_OK, STATUS_TERMINATED} and res.terminated.any()
    for j in range(len(g)):
        t = _one_step_run(runner, 20.0, solver=TAYLOR, rel_tol=1e-10, abs_tol=1e-12, max_step=20.0, g=g[j],
                          gamma_dot=spin[j], beta_min=0.1)
        x = np.array(runner.slave.getReal([runner.vr[n] for n in STATES + ["energy"]]))
        # the library is built with FMA contraction (rounding differs from the FMU's build)
        assert abs(res.t_final[j] - t) < 1e-9, j
        np.testing.assert_allclose(res.x_final[j], x[:8], rtol=1e-9, atol=1e-8, err_msg=str(j))
        assert res.output("energy")[j] == pytest.approx(x[8], abs=1e-9)


def test_ensemble_lanes_tail_and_refill_equal_the_single_runs(paper, tmp_path):
    """N not a multiple of the lanes and trajectories ending at different times (falls): the
    lanes take the next trajectory as soon as theirs ends, and the job's tail runs with idle
    lanes (gw_ensemble.c, GW_ENSEMBLE_SINGLE_MAX 0).  7 trajectories on 1, 4 and 8 lanes (the
    4-lane run ends with 3 lanes idle, the 8-lane one starts with 7 of 8 lanes; on a grid, each
    lane's calls end at every point) equal
    the 8-lane run of test_ensemble_equals_single_runs's kind: the same steps, the same values
    to rounding (each lane count's kernel rounds its own way under FMA contraction)."""
    built, runner = paper
    g = np.array([9.81, 3.721, 9.81, 9.81, 0.0, 9.81, 5.0])
    spin = np.array([6.0, 6.0, 1.0, 0.5, 3.0, 8.0, 0.2])
    kw = dict(parameters={"g": g, "beta_min": 0.1}, starts={"gamma_dot": spin}, rel_tol=1e-9)
    runs = {w: Ensemble(built.fmu, lanes=w, cache=tmp_path).run(6.0, **kw) for w in (1, 4, 8)}
    gridded = {w: Ensemble(built.fmu, lanes=w, cache=tmp_path).run(6.0, grid=np.linspace(0.5, 6.0, 12), **kw)
               for w in (1, 4)}
    ref = runs[8]
    assert 0 < ref.terminated.sum() < len(g) and set(ref.status) <= {STATUS_OK, STATUS_TERMINATED}
    for res in [runs[1], runs[4], *gridded.values()]:
        assert list(res.status) == list(ref.status)
        np.testing.assert_allclose(res.t_final, ref.t_final, rtol=0, atol=1e-9)
        np.testing.assert_allclose(res.x_final, ref.x_final, rtol=1e-9, atol=1e-8)
    for w in (1, 4):
        assert list(runs[w].steps) == list(ref.steps)
    np.testing.assert_allclose(gridded[1].y_grid, gridded[4].y_grid, rtol=1e-9, atol=1e-8)
    for j in (0, 2):  # one that runs to the end, one that falls: as one fmi2DoStep run
        t = _one_step_run(runner, 6.0, solver=TAYLOR, rel_tol=1e-9, abs_tol=1e-11, max_step=6.0, g=g[j],
                          gamma_dot=spin[j], beta_min=0.1)
        assert abs(ref.t_final[j] - t) < 1e-9
        np.testing.assert_allclose(ref.x_final[j], runner.slave.getReal([runner.vr[n] for n in STATES]),
                                   rtol=1e-9, atol=1e-8)


def test_ensemble_reports_bad_trajectories_and_names(paper, tmp_path):
    built, _ = paper
    ens = Ensemble(built.fmu, cache=tmp_path)
    res = ens.run(1.0, parameters={"M": [2.0, -1.0]}, rel_tol=1e-8)
    assert list(res.status) == [STATUS_OK, 3]
    assert any("ensemble trajectory 1" in m for m in res.messages)
    # an error while integrating names its trajectory too (which of N?)
    res = ens.run(2.0, starts={"gamma_dot": [6.0, 6.0, 1e9, 6.0]}, rel_tol=1e-8)
    assert list(res.status) == [STATUS_OK, STATUS_OK, 3, STATUS_OK]
    assert res.messages and all(m.startswith("ensemble trajectory 2: ") for m in res.messages), res.messages
    assert "max_internal_steps" in res.messages[0]
    # a start or parameter that is not finite: one message per value, naming it and its trajectory
    res = ens.run(1.0, starts={"beta": [1.2, np.nan, np.inf]}, parameters={"M": [2.0, 2.0, -np.inf]}, rel_tol=1e-8)
    assert list(res.status) == [STATUS_OK, 3, 3]
    assert res.messages == ["ensemble trajectory 1: start value beta is not finite (nan)",
                            "ensemble trajectory 2: parameter M is not finite (-inf)",
                            "ensemble trajectory 2: start value beta is not finite (inf)"], res.messages
    res = ens.run(1.0, starts={"beta_deg": [80.0, np.inf]}, rel_tol=1e-8)  # named as the caller gave it
    assert list(res.status) == [STATUS_OK, 3]
    assert res.messages == ["ensemble trajectory 1: start value beta (given as beta_deg) is not finite (inf)"]
    with pytest.raises(UnknownNameError, match="unknown parameter 'mass'") as info:  # a KeyError
        ens.run(1.0, parameters={"mass": [1.0]})
    assert isinstance(info.value, KeyError) and str(info.value).startswith("unknown parameter 'mass'")
    with pytest.raises(UnknownNameError, match="no output 'nope'; outputs: x, y"):
        res.output("nope")
    with pytest.raises(ArgumentError, match=r"shape \(N, 6\)"):
        ens.run(1.0, parameters=np.ones((2, 3)))
    # more trajectories than the memory holds: a message naming them, not numpy's MemoryError
    huge = np.broadcast_to(2.0, (10**12,))  # a view: no memory of its own
    with pytest.raises(ArgumentError, match="do not fit in this process's memory: run fewer trajectories"):
        ens.run(1.0, parameters={"M": huge})
    with pytest.MonkeyPatch.context() as mp:  # a 1 MiB machine: the tables fit, the run's buffer not
        from gyrowheel import arguments
        mp.setattr(arguments, "physical_memory", lambda: 2**20)
        with pytest.raises(ArgumentError, match=r"^100000 trajectories would take .* GiB, more than half of this "
                                                r"machine's 0.000977 GiB: run fewer trajectories per call"):
            ens.run(1.0, parameters={"M": np.full(10**5, 2.0)})


def test_ensemble_bad_job_names_the_field(paper, tmp_path):
    """A bad t_end, tolerance, max_step or grid is a ValueError naming the field, not the C
    library's catch-all 'ensemble: bad job (n >= 0, status, t_end > t_start, ...)'; so is a
    bad lane count or define."""
    built, _ = paper
    ens = Ensemble(built.fmu, cache=tmp_path)
    nan = float("nan")
    cases = [({"t_end": -1.0}, "t_end = -1.0 must be greater than t_start"),
             ({"t_end": nan}, "t_start and t_end must be finite"),
             ({"t_end": float("inf")}, "t_start and t_end must be finite"),
             ({"t_end": 1.0, "rel_tol": 0.0}, "rel_tol must be a finite number > 0"),
             ({"t_end": 1.0, "rel_tol": nan}, "rel_tol must be a finite number > 0"),
             # the FMU's range, once for the job (not one error per trajectory)
             ({"t_end": 1.0, "rel_tol": 1e-16, "starts": {"gamma_dot": [5.0] * 9}},
              "rel_tol must be within [2.220446049250313e-15, 1] (10 eps to 1), got 1e-16"),
             ({"t_end": 1.0, "rel_tol": 2.0}, "rel_tol must be within [2.220446049250313e-15, 1]"),
             ({"t_end": 1.0, "abs_tol": -1.0}, "abs_tol must be a finite number >= 0"),
             ({"t_end": 1.0, "max_step": 0.0}, "max_step must be a finite number > 0"),
             ({"t_end": 1.0, "grid": [0.5, 0.9]}, "last communication point 0.9 must equal t_end"),
             ({"t_end": 1.0, "grid": [0.5, 0.4, 1.0]}, "must increase strictly"),
             ({"t_end": 1.0, "grid": [0.0, 0.5, 1.0]}, "must increase strictly after t_start"),
             ({"t_end": 1.0, "grid": [0.5, nan, 1.0]}, "must be finite")]
    for kwargs, message in cases:
        t_end = kwargs.pop("t_end")
        with pytest.raises(ArgumentError, match=re.escape(message)):  # a ValueError
            ens.run(t_end, **kwargs)
    res = ens.run(1.0, rel_tol=1e-8, grid=[0.5, 1.0])  # a good job still runs
    assert list(res.status) == [STATUS_OK]
    lowest = ens.run(0.01, rel_tol=2.220446049250313e-15)  # the bound itself is in the range
    assert list(lowest.status) == [STATUS_OK]
    # lanes: 0 or -1 would fail in the compiler, 2.5 would be truncated to 2 silently
    for lanes in (0, -1, 2.5, "4", True):
        with pytest.raises(ArgumentError, match="lanes must be an integer >= 1"):
            Ensemble(built.fmu, lanes=lanes, cache=tmp_path)
    # defines: C macros of the build, each a #define line of the library's unity file
    for defines, message in (({"1X": 1}, "defines: '1X' is not a C identifier"),
                             ({"GW_X": "1\n#include <x>"}, "defines: GW_X must be an integer or a one-line string"),
                             ({"GW_X": 1.5}, "defines: GW_X must be an integer or a one-line string"),
                             ([("GW_X", 1)], "defines must be a {name: value} dict")):
        with pytest.raises(ArgumentError, match=re.escape(message)):
            Ensemble(built.fmu, cache=tmp_path, defines=defines)


def test_ensemble_of_a_file_that_is_no_fmu_names_it(tmp_path):
    """The fmu argument: a missing file, a directory, a file that is no zip archive, a zip without
    modelDescription.xml: an FmuError (a gyrowheel.GyrowheelError and a ValueError) naming the
    file, never Python's FileNotFoundError / BadZipFile / KeyError from the archive."""
    import zipfile
    (tmp_path / "text.fmu").write_text("not a zip")
    with zipfile.ZipFile(tmp_path / "empty.fmu", "w") as zf:
        zf.writestr("readme.txt", "no model description")
    cases = [(tmp_path / "missing.fmu", "no such FMU file"), (tmp_path, "is a directory"),
             (tmp_path / "text.fmu", "not a zip archive"), (tmp_path / "empty.fmu", "no modelDescription.xml")]
    for path, message in cases:
        with pytest.raises(FmuError, match=re.escape(f"{path}: ") + ".*" + re.escape(message)) as info:
            Ensemble(path, cache=tmp_path / "cache")
        assert info.value.argument == "fmu" and isinstance(info.value, ValueError)
    # a scene, as a file or a Scene: say so, and how to build the FMU the ensemble needs
    from gyrowheel.fmu_build.scene import load_scene
    build = ("build its FMU with the Taylor kernel first: gyrowheel.build(scene, output, taylor=True) or "
             "`gyrowheel build --taylor SCENE -o FMU` (or solver = \"taylor\" in the scene's [experiment])")
    for fmu, message in ((SCENES / "paper_moon.toml", f"{SCENES / 'paper_moon.toml'}: a scene, not an FMU; {build}"),
                         (load_scene(SCENES / "paper_moon.toml"), f"fmu: a gyrowheel.Scene, not an FMU; {build}")):
        with pytest.raises(FmuError) as info:
            Ensemble(fmu, cache=tmp_path / "cache")
        assert str(info.value) == message and info.value.argument == "fmu"
    with pytest.raises(ArgumentTypeError, match="fmu must be a path to an FMU .* got int"):
        Ensemble(3, cache=tmp_path / "cache")


def test_ensemble_runs_at_the_fmus_tolerance_by_default(paper, tmp_path):
    """run() without rel_tol is the FMU's run with solver taylor: its rel_tol (1e-8 in
    paper_earth's scene), abs_tol rel_tol / 100 (the FMU's abs_tol 0); the final states equal
    fmi2DoStep's at those settings to rounding (the library fuses multiply-adds)."""
    built, runner = paper
    ens = Ensemble(built.fmu, cache=tmp_path)
    assert (ens.rel_tol, ens.abs_tol) == (1e-8, 0.0)
    default = ens.run(2.0, starts={"gamma_dot": [6.0, 7.0]})
    named = ens.run(2.0, starts={"gamma_dot": [6.0, 7.0]}, rel_tol=1e-8, abs_tol=1e-10)
    np.testing.assert_array_equal(default.x_final, named.x_final)
    assert not np.array_equal(default.x_final, ens.run(2.0, starts={"gamma_dot": [6.0, 7.0]}, rel_tol=1e-10).x_final)
    alone = np.array(runner.one_step(2.0, STATES, solver=TAYLOR, gamma_dot=7.0, max_step=2.0))
    np.testing.assert_allclose(default.x_final[1], alone, rtol=1e-9, atol=1e-12)


def test_ensemble_takes_angles_in_degrees_as_name_deg(paper, tmp_path):
    """starts={"beta_deg": ...}: the angle beta (unit rad) in degrees, as scenes, simulate and
    sweep take it; the same bits as the radians; a non-angle's _deg and a name given twice are
    refused naming them."""
    built, _ = paper
    ens = Ensemble(built.fmu, cache=tmp_path)
    deg = ens.run(2.0, starts={"beta_deg": [70.0, 80.0], "gamma_dot": 6.0}, rel_tol=1e-8)
    rad = ens.run(2.0, starts={"beta": np.radians([70.0, 80.0]), "gamma_dot": 6.0}, rel_tol=1e-8)
    np.testing.assert_array_equal(deg.x_final, rad.x_final)
    assert deg.x_final[1, STATES.index("beta")] != deg.x_final[0, STATES.index("beta")]
    with pytest.raises(UnknownNameError, match=r"unknown start value 'gamma_dot_deg'.*\(angles also as NAME_deg"):
        ens.run(1.0, starts={"gamma_dot_deg": 6.0})  # a rate (rad/s), not an angle
    with pytest.raises(ArgumentError, match="start value 'beta' given twice: as 'beta' and as 'beta_deg'"):
        ens.run(1.0, starts={"beta": 1.2, "beta_deg": 70.0})
    with pytest.raises(ArgumentError, match="start value 'beta_deg' must be a number"):
        ens.run(1.0, starts={"beta_deg": "steep"})


def test_ensemble_under_a_process_memory_limit_names_the_run(paper, tmp_path):
    """A process limited below the machine's memory (ulimit -v, a container): a run whose buffer
    does not fit is an ArgumentError naming the trajectories and the way out, not numpy's
    MemoryError (the memory rule compares with the machine's memory only)."""
    import subprocess
    import sys
    built, _ = paper
    code = ("import resource, sys, numpy as np\n"
            "from gyrowheel.taylor.ensemble import Ensemble\n"
            "ens = Ensemble(sys.argv[1], cache=sys.argv[2])\n"
            "resource.setrlimit(resource.RLIMIT_AS, (6 << 30, 6 << 30))\n"
            "try:\n"
            "    ens.run(1e-6, starts={'gamma_dot': np.broadcast_to(6.0, (30_000_000,))})\n"
            "except Exception as exc:\n"
            "    print(type(exc).__name__, exc)\n")
    r = subprocess.run([sys.executable, "-c", code, str(built.fmu), str(tmp_path)], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.startswith("ArgumentError 30000000 trajectories: the run's "), r.stdout + r.stderr
    assert r.stdout.rstrip().endswith("do not fit in this process's memory: run fewer trajectories per call"), r.stdout


def test_ensemble_counts_trajectories_over_parameters_and_starts(paper, tmp_path):
    """N is the length of every column with more than one value, in parameters and starts alike;
    a column of one value is that value for all N, either way round; columns of different
    lengths are one ArgumentError naming each with its length."""
    built, _ = paper
    ens = Ensemble(built.fmu, cache=tmp_path)
    for kwargs in (dict(parameters={"M": [2.0]}, starts={"gamma_dot": [5.0, 6.0, 7.0]}),
                   dict(parameters={"M": [2.0, 2.0, 2.0]}, starts={"gamma_dot": 6.0}),
                   dict(parameters={"M": 2.0, "R": [0.17, 0.17, 0.17]})):
        assert len(ens.run(0.1, rel_tol=1e-8, **kwargs).status) == 3, kwargs
    one = ens.run(0.1, rel_tol=1e-8, parameters={"M": [2.5]}, starts={"gamma_dot": [5.0, 7.0]})
    both = ens.run(0.1, rel_tol=1e-8, parameters={"M": [2.5, 2.5]}, starts={"gamma_dot": [5.0, 7.0]})
    np.testing.assert_array_equal(one.x_final, both.x_final)
    with pytest.raises(ArgumentError, match=re.escape(
            "parameters and starts give different numbers of trajectories: starts['beta_deg'] (2 values), "
            "starts['gamma_dot'] (3 values); give each column one value per trajectory, or one value for all")):
        ens.run(1.0, starts={"beta_deg": [70.0, 80.0], "gamma_dot": [1.0, 2.0, 3.0]})
    with pytest.raises(ArgumentError, match=re.escape("parameters['M'] (2 values), starts (3 rows)")):
        ens.run(1.0, parameters={"M": [2.0, 3.0]}, starts=np.tile(ens.default_starts, (3, 1)))


def test_ensemble_bad_values_name_the_field(paper, tmp_path):
    """A value that is not a number names its field (not numpy's "could not convert string to
    float: 'heavy'" for {'M': 'heavy'}, a broadcast error for a 2-D column, a silent NaN start
    for {'gamma_dot': None}); a time or tolerance given as text ('10') is refused as every
    gyrowheel function refuses it, an ArgumentTypeError (a TypeError) naming it."""
    built, _ = paper
    ens = Ensemble(built.fmu, cache=tmp_path)
    cases = [({"parameters": {"M": "heavy"}}, "parameter 'M' must be a number"),
             ({"parameters": {"M": [[1.0, 2.0], [3.0, 4.0]]}}, "parameter 'M' must be a number"),
             ({"starts": {"gamma_dot": None}}, "start value 'gamma_dot' must be a number"),
             ({"starts": {"gamma_dot": [5.0, None]}}, "start value 'gamma_dot' must be a number"),
             # a Boolean is no number (True ran as 1 degree)
             ({"starts": {"beta_deg": [True]}}, "start value 'beta_deg' must be a number"),
             ({"starts": {"beta": np.array([True, False])}}, "start value 'beta' must be a number"),
             ({"abs_tol": 1e300}, "abs_tol must be 0 (rel_tol / 100) or within [1e-30, 1], got 1e+300"),
             ({"abs_tol": 1e-40}, "abs_tol must be 0 (rel_tol / 100) or within [1e-30, 1], got 1e-40"),
             ({"parameters": [["a"] * len(ens.parameter_names)]}, "parameters must be an (N, 6) array of numbers"),
             ({"grid": "abc"}, "grid must be a sequence of communication points")]
    for kwargs, message in cases:
        with pytest.raises(ValueError, match=re.escape(message)):
            ens.run(1.0, **kwargs)
    with pytest.raises(ArgumentTypeError, match=re.escape("start value names must be strings, got tuple ('beta_deg',)")):
        ens.run(1.0, starts={("beta_deg",): [70.0]})
    for name, text in (("t_end", "10"), ("t_start", "0"), ("rel_tol", "1e-8"), ("abs_tol", "1e-10"),
                       ("max_step", "0.5")):
        kwargs = {"t_end": 1.0, name: text}
        with pytest.raises(ArgumentTypeError, match=re.escape(f"{name} must be a number, got str {text!r}")) as info:
            ens.run(kwargs.pop("t_end"), **kwargs)
        assert info.value.argument == name and isinstance(info.value, TypeError)
    as_numpy = ens.run(np.float64(1.0), t_start=np.int64(0), rel_tol=np.float32(1e-8), max_step=0.5, grid=[0.5, 1.0])
    assert list(as_numpy.status) == [STATUS_OK]
    objects = np.array([ens.default_parameters], dtype=object)  # numbers held as objects still run
    assert np.array_equal(ens.run(1.0, parameters=objects, rel_tol=1e-8).x_final,
                          ens.run(1.0, rel_tol=1e-8).x_final)


@pytest.mark.parametrize("step_fm", [1, 0], ids=["fastmath-step", "libm-step"])
def test_ensemble_lane_innermost_passes_equal_the_per_lane_code(paper, tmp_path, step_fm):
    """The batch's lane-innermost passes (gw_ensemble.c: the step size norms, the step sizes, the
    defects, the increments' Horner sums of all lanes at once) give each lane the numbers of
    solver taylor's one-lane code bit for bit: the same library built with
    GW_ENSEMBLE_LANE_STEPS=1 (every lane through gw_taylor_step / _defect / _increment on its own
    copy of the series) returns equal steps, times, states and grid outputs, with N not a
    multiple of the lanes, falls at different times, refills and a communication grid.  Both
    step size forms: the library's gw_fm_logexp.h ln and exp (4 lanes per vector call against
    the scalar calls), and libm's (GW_TAYLOR_STEP_FM 0, the FMU's: a loop over the lanes)."""
    assert "#define GW_TAYLOR_STEP_FM 1" in (C_SRC / "gw_ensemble_lib.c").read_text()  # the library's default
    defines = {} if step_fm else {"GW_TAYLOR_STEP_FM": 0}
    built, _ = paper
    g = np.array([9.81, 3.721, 9.81, 9.81, 0.0, 9.81, 5.0, 1.625, 9.81])
    spin = np.array([6.0, 6.0, 1.0, 0.5, 3.0, 8.0, 0.2, 4.0, 6.1])
    kw = dict(parameters={"g": g, "beta_min": 0.1}, starts={"gamma_dot": spin}, rel_tol=1e-7)
    grid = np.linspace(0.5, 6.0, 12)
    passes = Ensemble(built.fmu, lanes=4, cache=tmp_path, defines=defines)
    per_lane = Ensemble(built.fmu, lanes=4, cache=tmp_path, defines={**defines, "GW_ENSEMBLE_LANE_STEPS": 1})
    for extra in ({}, {"grid": grid}):
        a, b = passes.run(6.0, **kw, **extra), per_lane.run(6.0, **kw, **extra)
        assert 0 < a.terminated.sum() < len(g)
        assert list(a.status) == list(b.status) and list(a.steps) == list(b.steps)
        np.testing.assert_array_equal(a.t_final, b.t_final)
        np.testing.assert_array_equal(a.x_final, b.x_final)
        if extra:
            np.testing.assert_array_equal(a.y_grid, b.y_grid)


def test_ensemble_advice_is_what_run_can_do(paper, tmp_path):
    """A trajectory the budget of internal steps stops is told what Ensemble.run can change (it
    has no max_internal_steps): a grid, since the budget is per communication step; and a grid
    carries the same run through."""
    built, _ = paper
    ens = Ensemble(built.fmu, cache=tmp_path)
    kw = dict(parameters={"g": [1.625]}, starts={"gamma_dot": [8.0]})
    res = ens.run(1e5, **kw)
    assert list(res.status) == [3] and len(res.messages) == 1
    message = res.messages[0]
    assert message.startswith("ensemble trajectory 0: at t=") and "raise max_internal_steps" not in message
    assert ("steps taken in this call): shorten the communication steps: give run() a grid (the budget of "
            "max_internal_steps is per communication step; without a grid the run from t_start to t_end is one "
            "step), or a shorter t_end; if steps of ") in message, message
    assert message.endswith("the dynamics are too fast for the tolerance (huge rates?) or stiff (then simulate "
                            "the FMU with solver rosenbrock: the ensemble runs solver taylor)"), message
    res = ens.run(1e5, **kw, grid=np.linspace(1e4, 1e5, 10))
    assert list(res.status) == [STATUS_OK] and res.t_final[0] == 1e5 and not res.messages


def test_ensemble_grid_too_large_for_the_memory(paper, tmp_path, monkeypatch):
    """The outputs at every point of a grid, for every trajectory, fall under the memory rule of
    every run that collects rows (gyrowheel.arguments.check_memory): refused naming grid."""
    import gyrowheel.arguments
    built, _ = paper
    ens = Ensemble(built.fmu, cache=tmp_path)
    monkeypatch.setattr(gyrowheel.arguments, "physical_memory", lambda: 4096)
    with pytest.raises(ArgumentError) as info:
        ens.run(1.0, starts={"gamma_dot": [6.0] * 8}, grid=np.linspace(0.01, 1.0, 100))
    assert info.value.argument == "grid"
    assert str(info.value).startswith(f"grid: 8 trajectories of 101 communication points of {ens.ny} outputs would "
                                      f"take ") and str(info.value).endswith(
        "GiB: give a coarser grid, or fewer trajectories per run")
    monkeypatch.undo()
    assert list(ens.run(1.0, starts={"gamma_dot": [6.0] * 8}, grid=np.linspace(0.01, 1.0, 100)).status) == [0] * 8
