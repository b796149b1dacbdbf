"""A scene's [experiment] (gyrowheel.fmu_build.scene): the Experiment dataclass, the FMU's
DefaultExperiment and the defaults of its solver parameters, and the solver items of the FMU's
Enumeration `solver` (c_src/gw_model.h, gw_solver)."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

SOLVERS = {"euler": 1, "rk4": 2, "dopri5": 3, "rosenbrock": 4, "dop853": 5, "taylor": 6, "auto": 7}


@dataclass
class Experiment:
    """A scene's [experiment]: the FMU's DefaultExperiment and the defaults of its solver
    parameters (docs/scenes.md, docs/fmi.md); all can still be set when the FMU is used.

    start_time        s, DefaultExperiment startTime (any finite number)
    stop_time         s, DefaultExperiment stopTime, > start_time
    output_interval   s, > 0: DefaultExperiment stepSize, the communication step of
                      gyrowheel simulate
    solver            the FMU's Enumeration parameter `solver`: one of SOLVERS (euler, rk4,
                      dopri5, rosenbrock, dop853, taylor, auto; taylor also puts the Taylor
                      kernel into the FMU, docs/taylor.md); auto (the default) integrates with
                      taylor where the FMU has the kernel and no contact modes, else dop853, docs/accuracy.md
                      "Solver auto"
    rel_tol           1, relative tolerance of the adaptive solvers in [10 eps, 1] (10 eps = 2.2204460492503131e-15); also
                      DefaultExperiment tolerance
    abs_tol           1, absolute tolerance (scaled by each state's nominal value) in [1e-30, 1],
                      or 0 (the default): rel_tol / 100, following the tolerance in force
    max_step          s, > 0: bound of the internal step (the fixed step of euler and rk4);
                      default (None): stop_time - start_time under solver auto (the step
                      follows the tolerance alone), 0.01 s under the others
    max_internal_steps  whole number in [1, 2**31 - 1]: budget of internal steps of one
                      fmi2DoStep (docs/fmi.md, "Bounded calls")
    """

    start_time: float = 0.0
    stop_time: float = 20.0
    output_interval: float = 0.01
    solver: str = "auto"
    rel_tol: float = 1e-8
    abs_tol: float = 0.0  # 0: follow rel_tol (rel_tol / 100, so a tolerance-only run has no floor)
    max_step: float | None = None  # None: the run's length under auto, else FIXED_SOLVER_MAX_STEP
    max_internal_steps: int = 1_000_000  # budget of internal steps of one fmi2DoStep (docs/fmi.md)

    @property
    def max_step_in_force(self) -> float:
        """s: max_step, or where it is None its default, resolved from the experiment as it is
        now (a later change of solver, start_time or stop_time moves it): the run's length under
        auto, FIXED_SOLVER_MAX_STEP under a named solver. NaN where the times are not numbers
        (the scene's rules refuse those, naming the key)."""
        if self.max_step is not None:
            return self.max_step
        try:
            run = float(self.stop_time) - float(self.start_time)
        except (TypeError, ValueError):
            run = math.nan
        return run if self.solver == "auto" and run > 0 else FIXED_SOLVER_MAX_STEP

    def resolved(self) -> "Experiment":
        """A copy with max_step resolved (max_step_in_force): what the FMU is built with."""
        return replace(self, max_step=self.max_step_in_force)

FIXED_SOLVER_MAX_STEP = 0.01  # s: the default max_step of a scene that names its solver
