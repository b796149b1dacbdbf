"""Time the FMU's own integrator: instantiate, initialise, one fmi2DoStep."""
from __future__ import annotations

import time
from pathlib import Path

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

_CACHE: dict[str, tuple] = {}


def _open(fmu: Path):
    key = str(fmu)
    if key not in _CACHE:
        md = read_model_description(key)
        _CACHE[key] = (md, extract(key))
    return _CACHE[key]


def one_step_seconds(fmu: Path, stop: float, **values) -> float:
    """CPU time of fmi2DoStep(0, stop) alone (instantiation and set-up excluded)."""
    md, unzipdir = _open(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier)
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    for name, value in values.items():
        s.setReal([vr[name]], [value])
    s.enterInitializationMode()
    s.exitInitializationMode()
    t0 = time.perf_counter()
    s.doStep(0.0, stop)
    dt = time.perf_counter() - t0
    s.terminate()
    s.freeInstance()
    return dt
