"""The arguments of Ensemble and Ensemble.run named on their errors (gyrowheel.errors: an error
about one argument carries its name as `argument`), and a communication grid that is not 1-D
refused with its shape rather than flattened into other communication points."""
from __future__ import annotations

import re

import numpy as np
import pytest

from gyrowheel.errors import ArgumentError, ArgumentTypeError, UnknownNameError
from gyrowheel.taylor.ensemble import STATUS_OK, Ensemble
from gyrowheel.taylor.ensemble_job import check_job


@pytest.fixture(scope="module")
def ens(example_build, tmp_path_factory):
    return Ensemble(example_build("paper_earth", taylor=True).fmu, cache=tmp_path_factory.mktemp("ensemble"))


@pytest.mark.parametrize("grid, shape", [([[0.5], [1.0]], "(2, 1)"), ([[0.25, 0.5], [0.75, 1.0]], "(2, 2)"),
                                         (1.0, "()")])
def test_a_grid_that_is_not_1d_is_refused_with_its_shape(ens, grid, shape):
    """[[0.5], [1.0]] would run as the grid [0.5, 1.0], a 2x2 table as four points: refused."""
    with pytest.raises(ArgumentError) as info:
        ens.run(1.0, rel_tol=1e-8, grid=grid)
    assert str(info.value) == (f"grid must be 1-D, a sequence of communication points (numbers, s), got shape "
                               f"{shape}")
    assert info.value.argument == "grid"
    res = ens.run(1.0, rel_tol=1e-8, grid=[0.5, 1.0])  # the same points as a 1-D grid run
    assert list(res.status) == [STATUS_OK] and list(res.grid) == [0.0, 0.5, 1.0]


@pytest.mark.parametrize("grid", [[], (), np.array([])])
def test_an_empty_grid_is_refused_not_read_as_no_grid(grid):
    """A grid ends at t_end (docs/taylor.md); an empty one was run as if grid were left out."""
    with pytest.raises(ArgumentError, match=r"^grid must hold the communication points up to t_end = 1\.0 \(the "
                                            r"last equal to it\), got none; leave grid out") as info:
        check_job(0.0, 1.0, 1e-8, None, None, grid)
    assert info.value.argument == "grid"
    assert check_job(0.0, 1.0, 1e-8, None, None, None).size == 0  # no grid: the run to t_end


@pytest.mark.parametrize("kwargs, argument, message", [
    (dict(t_end=-1.0), "t_end", "t_end = -1.0 must be greater than t_start = 0.0"),
    (dict(t_end=float("inf")), "t_end", "t_start and t_end must be finite, got 0.0 and inf"),
    (dict(t_start=float("nan")), "t_start", "t_start and t_end must be finite, got nan and 1.0"),
    (dict(t_start=float("nan"), t_end=float("inf")), None, "t_start and t_end must be finite"),
    (dict(rel_tol=0.0), "rel_tol", "rel_tol must be a finite number > 0"),
    (dict(rel_tol=2.0), "rel_tol", "rel_tol must be within"),
    (dict(abs_tol=-1.0), "abs_tol", "abs_tol must be a finite number >= 0"),
    (dict(abs_tol=1e-40), "abs_tol", "abs_tol must be 0 (rel_tol / 100) or within"),
    (dict(max_step=0.0), "max_step", "max_step must be a finite number > 0"),
    (dict(grid="abc"), "grid", "grid must be a sequence of communication points"),
    (dict(grid=[0.5, float("nan"), 1.0]), "grid", "grid: communication points must be finite"),
    (dict(grid=[0.5, 0.4, 1.0]), "grid", "grid: communication points must increase strictly"),
    (dict(grid=[0.5, 0.9]), "grid", "grid: the last communication point 0.9 must equal t_end = 1.0"),
])
def test_the_jobs_errors_name_their_argument(kwargs, argument, message):
    job = dict(t_start=0.0, t_end=1.0, rel_tol=1e-8, abs_tol=None, max_step=None, grid=None)
    with pytest.raises(ArgumentError, match=re.escape(message)) as info:
        check_job(**{**job, **kwargs})
    assert info.value.argument == argument


def test_the_values_errors_name_their_argument(ens, tmp_path):
    """parameters and starts (an unknown name, a value that is no number, a table of the wrong
    shape, a name given twice), an output's name, the lanes and the defines."""
    cases = [(dict(parameters={"mass": [1.0]}), UnknownNameError, "parameters", "unknown parameter 'mass'"),
             (dict(starts={"spin": 1.0}), UnknownNameError, "starts", "unknown start value 'spin'"),
             (dict(parameters={"M": "heavy"}), ArgumentError, "parameters", "parameter 'M' must be a number"),
             (dict(starts={"beta_deg": "steep"}), ArgumentError, "starts", "start value 'beta_deg' must be a number"),
             (dict(starts={"beta": 1.2, "beta_deg": 70.0}), ArgumentError, "starts", "given twice"),
             (dict(parameters=np.ones((2, 3))), ArgumentError, "parameters", "parameters must have shape (N, 6)"),
             (dict(starts=[["a"]]), ArgumentError, "starts", "start values must be an (N, "),
             (dict(starts={1: 1.0}), ArgumentTypeError, "starts", "start value names must be strings")]
    for kwargs, kind, argument, message in cases:
        with pytest.raises(kind, match=re.escape(message)) as info:
            ens.run(1.0, rel_tol=1e-8, **kwargs)
        assert info.value.argument == argument, kwargs
    res = ens.run(0.1, rel_tol=1e-8)
    with pytest.raises(UnknownNameError, match="no output 'nope'; outputs: x, y") as info:
        res.output("nope")
    assert info.value.argument == "name"
    for kwargs, argument in ((dict(lanes=0), "lanes"), (dict(defines={"1X": 1}), "defines"),
                             (dict(defines=[("GW_X", 1)]), "defines")):
        with pytest.raises(ArgumentError) as info:
            Ensemble(ens.fmu, cache=tmp_path, **kwargs)
        assert info.value.argument == argument, kwargs
