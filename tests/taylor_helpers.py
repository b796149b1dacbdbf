"""Helpers of the Taylor and ensemble tests (not a test module: nothing here is collected)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"
TAYLOR = 6  # the solver enumeration's taylor (fmu_build/scene.py SOLVERS)


def fmu_runner(fmu):
    """benchmarks/fmi_slave.FmuRunner of `fmu`: a Co-Simulation instance started anew by
    start(**values), one fmi2DoStep per one_step(stop, names, **values)."""
    if str(BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(BENCHMARKS))
    from fmi_slave import FmuRunner
    return FmuRunner(fmu)


def one_step(runner, stop: float, names: list[str], **values) -> np.ndarray:
    """The values of `names` after one fmi2DoStep(0, stop) from `values` (max_step defaults to
    stop)."""
    values.setdefault("max_step", stop)
    return np.array(runner.one_step(stop, names, **values))


def same_results(a, b) -> None:
    """Two ensemble results equal bit for bit: status, steps, final times and states, grid
    outputs and rows, event flags, messages."""
    assert list(a.status) == list(b.status) and list(a.steps) == list(b.steps)
    np.testing.assert_array_equal(a.t_final, b.t_final)
    np.testing.assert_array_equal(a.x_final, b.x_final)
    np.testing.assert_array_equal(a.y_grid, b.y_grid)
    np.testing.assert_array_equal(a.n_rows, b.n_rows)
    np.testing.assert_array_equal(a.flags, b.flags)
    assert a.messages == b.messages
