"""Run a system's .ssp in ecos (ecospy, the Vico co-simulation engine's Python package).

ecos reads the .ssp itself (SystemStructure.ssd, parameter bindings, connections) and steps every
component with the fixed step; identifiers are "<component>::<variable>". Samples are taken at
every communication point and returned like gyrowheel.cosim.master.run's result (time,
<component>.<variable>). ecospy needs Debian's libtbb12 (.ci/run and `make test` install it).
"""
from __future__ import annotations

import numpy as np


def run(ssp: str, step: float, stop_time: float, variables: dict[str, list[str]],
        parameter_set: str | None = None) -> np.ndarray:
    """Simulate the .ssp with ecos at fixed step `step` [s] to stop_time and sample `variables`
    ({component: [names]}). ecos applies parameter bindings only of the set named at
    initialisation: parameter_set (the files gyrowheel.cosim.ssp.write_ssp writes name every set
    gyrowheel.cosim.system.PARAMETER_SET, "start"). Raises RuntimeError if ecos refuses the file or a step."""
    from ecospy import EcosSimulation

    names = [(c, v) for c, vs in variables.items() for v in vs]
    n = int(round(stop_time / step))
    rows = []
    try:
        with EcosSimulation(step_size=step, ssp_path=str(ssp)) as sim:
            if sim.init(parameter_set=parameter_set) is False:
                raise RuntimeError("ecos could not initialise the system")

            def sample():
                rows.append([sim.get_time()] + [sim.get_real(f"{c}::{v}") for c, v in names])
            sample()
            for _ in range(n):
                sim.step()
                sample()
    except RuntimeError:
        raise
    except Exception as exc:  # ecospy raises plain Exceptions with ecos' last error
        raise RuntimeError(f"ecos: {exc}") from None
    data = np.zeros(len(rows), dtype=[("time", np.float64)] + [(f"{c}.{v}", np.float64) for c, v in names])
    for j, name in enumerate(data.dtype.names):
        data[name] = [r[j] for r in rows]
    return data
