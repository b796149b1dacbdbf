"""Run a system in libcosim (libcosimpy): from the .ssp itself or from OspSystemStructure.xml.

libcosim counts time in integer nanoseconds. Samples are taken every step with a time-series
observer and returned like gyrowheel.cosim.master.run's result (time, <component>.<variable>).
"""
from __future__ import annotations

import numpy as np
from fmpy import read_model_description

from gyrowheel.cosim.system import SystemDescription, SystemFileError

NS = 1_000_000_000


def run(config: str, system: SystemDescription, step: float, stop_time: float,
        variables: dict[str, list[str]]) -> np.ndarray:
    """Simulate with libcosim and sample `variables` ({component: [names]}) at every step.

    config: path of an .ssp archive (libcosim's SSP loader, fixed step) or of an
    OspSystemStructure.xml. Raises RuntimeError if libcosim refuses the file or the run,
    SystemFileError for a component that is an FMI 3.0 FMU (refuse_fmi3).
    """
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver

    refuse_fmi3(system)
    h = int(round(step * NS))
    if config.endswith(".xml"):
        execution = CosimExecution.from_osp_config_file(config)
    else:
        execution = CosimExecution.from_ssp_file(config, step_size=h)
    observer = CosimObserver.create_time_series()
    execution.add_observer(observer=observer)
    names = ["time"]
    series = []
    for comp, outs in variables.items():
        index = execution.slave_index_from_instance_name(comp)
        md = read_model_description(str(system.component(comp).fmu), validate=False)
        vr = {v.name: v.valueReference for v in md.modelVariables}
        for o in outs:
            observer.start_time_series(index, vr[o], CosimVariableType.REAL)
            series.append((index, vr[o]))
            names.append(f"{comp}.{o}")
    n = int(round(stop_time * NS / h))
    if not execution.simulate_until(target_time=n * h):
        raise RuntimeError("libcosim stopped before the stop time")
    steps = None
    columns = []
    for index, vr in series:
        # libcosimpy returns (time points [ns], step numbers, values)
        t_ns, numbers, values = observer.time_series_real_samples(index, vr, from_step=0, sample_count=n + 2)
        by_step = dict(zip(numbers, values))
        steps = sorted(by_step) if steps is None else [k for k in steps if k in by_step]
        columns.append(by_step)
    data = np.zeros(len(steps), dtype=[(nm, np.float64) for nm in names])
    data["time"] = system.start_time + np.array(steps, dtype=float) * h / NS
    for nm, col in zip(names[1:], columns):
        data[nm] = [col[k] for k in steps]
    return data


def refuse_fmi3(system: SystemDescription) -> None:
    """libcosim (libcosimpy 0.0.x, libcosim 0.10) loads FMI 1.0 and 2.0 FMUs only: an FMI 3.0
    component is refused here, naming its file, rather than by libcosim's loader mid-setup."""
    for c in system.components:
        version = read_model_description(str(c.fmu), validate=False).fmiVersion
        if version.startswith("3."):
            raise SystemFileError(f"component {c.name!r}: {c.fmu}: an FMI {version} FMU; libcosim runs FMI 1.0 "
                                  f"and 2.0 FMUs only (gyrowheel's master and ecos run FMI 3.0)")
