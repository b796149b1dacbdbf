"""A batch of points through the ensemble path (gyrowheel.taylor.ensemble) when the unit's solver is taylor.

The plain path (gyrowheel.studies.batch.run_point) drives one FMU instance point after point;
when the unit is a gyrowheel FMU that carries the Taylor kernel and its solver for the sweep is
taylor (named, or auto, the default, in a model without mode switches: auto integrates with
taylor there), the same points can run several at a time (the machine's lane count,
gyrowheel.taylor.lanes.ensemble_lanes: 4 with AVX2, 8 or 4 with AVX-512F as they measure, else
2) with the Taylor coefficients of
all lanes computed together (c_src/gw_ensemble.c). Each lane is a full gw_instance advanced
from communication point to communication point as fmi2DoStep advances it (same grid
t_i = t0 + i h, the last landing on the stop time; the budget, event count and step guard of
each communication step), so a point's outputs and metrics equal the plain loop's to rounding
(the ensemble library is compiled with FMA contraction: tests/test_sweep_ensemble.py), but for
the flags of a grazing crossing: the lanes look at the event indicators at their step ends only,
so an indicator that dips below zero and back within one lane step fires in the plain loop only
(docs/sweeps.md, "The ensemble path"; tests/test_sweep_warning_flags.py).

It applies only when every value a point sets is a parameter or start value of the model and
the solver settings are common to the batch; otherwise (an input, a per-point solver setting,
a system of FMUs) the batch runs the plain way. A point that fails in the ensemble is run again
the plain way, so its row carries the FMU's own reason.
"""
from __future__ import annotations

import shutil
import threading
import time
from pathlib import Path

import numpy as np

from gyrowheel.studies.metrics import Run
from gyrowheel.scratch import temporary_directory
from gyrowheel.studies.target import PointFailure

TAYLOR, AUTO = 6, 7  # the solver enumeration's values (c_src/gw_model.h)
SETTINGS = ("solver", "rel_tol", "abs_tol", "max_step")
_ENSEMBLES: dict[str, object] = {}  # FMU digest -> Ensemble, per worker process
_LOCK = threading.Lock()


def _ensemble(target, payload):
    """The target's Ensemble (compiled once per machine, loaded once per process), or None."""
    from gyrowheel.taylor.ensemble import Ensemble, EnsembleError

    with _LOCK:
        if target.digest not in _ENSEMBLES:
            # the FMU's bytes in a private directory, removed once the library is loaded (the
            # library itself is cached by content): nothing is left in the shared temp
            # directory, and no file there that another user could have put is trusted
            with temporary_directory("sweep-ens") as tmp:
                fmu = Path(tmp) / "unit.fmu"
                if payload is not None:
                    fmu.write_bytes(payload)
                else:
                    shutil.copyfile(target.path, fmu)
                try:
                    _ENSEMBLES[target.digest] = Ensemble(fmu)  # the machine's lanes: ensemble_lanes
                except EnsembleError:
                    _ENSEMBLES[target.digest] = None
        return _ENSEMBLES[target.digest]


def _settings(target, fixed: dict) -> dict[str, float] | None:
    """solver settings of the batch (fixed values over the FMU's defaults), None unless the
    solver is taylor, or auto where auto integrates with taylor (the FMU's default)"""
    variables = target.variables()
    out = {}
    for name in SETTINGS:
        value = fixed.get(name, variables[name].start if name in variables else None)
        if value is None:
            return None
        out[name] = float(value)
    taylor = out["solver"] == TAYLOR or (out["solver"] == AUTO and getattr(target, "auto_taylor", False))
    return out if taylor else None


def applies(target, settings) -> bool:
    """Whether the batches of this sweep can take the ensemble path (cheap: no compilation)."""
    return bool(getattr(target, "taylor_kernel", False)) and _settings(target, settings.fixed) is not None


def run_batch_ensemble(target, payload, settings, metrics, batch: list, run_plain) -> list[dict] | None:
    """Rows of `batch` (as gyrowheel.studies.batch.run_batch returns them) through the ensemble, or
    None when the ensemble path does not apply (the caller then runs the batch the plain way).
    run_plain(points) runs the given [(point, values, inputs)] the plain way (failed points)."""
    if not applies(target, settings) or metrics.discrete:  # the ensemble records Real outputs only
        return None
    tol = _settings(target, settings.fixed)
    rest = {k: v for k, v in settings.fixed.items() if k not in SETTINGS}
    if any(set(values) & set(SETTINGS) for _, values, _ in batch):
        return None  # a per-point solver setting: one FMU run per point
    ens = _ensemble(target, payload)
    if ens is None or not set(target.outputs) <= set(ens.output_names) \
            or not set(target.flag_names) <= set(ens.event_names):
        return None
    known = set(ens.parameter_names) | set(ens.start_names)
    if any(not set({**rest, **values}) <= known for _, values, _ in batch):
        return None
    t0 = time.perf_counter()
    n_pts = len(batch)
    P = np.tile(ens.default_parameters, (n_pts, 1))
    S = np.tile(ens.default_starts, (n_pts, 1))
    for j, (_, values, _) in enumerate(batch):
        for name, value in {**rest, **values}.items():
            if name in ens.parameter_names:
                P[j, ens.parameter_names.index(name)] = float(value)
            else:
                S[j, ens.start_names.index(name)] = float(value)
    n, h = settings.grid()
    t_start = settings.start_time
    grid = np.array([settings.stop_time if i == n - 1 else t_start + (i + 1) * h for i in range(n)])
    res = ens.run(settings.stop_time, P, S, t_start=t_start, rel_tol=tol["rel_tol"],
                  abs_tol=tol["abs_tol"], max_step=tol["max_step"], grid=grid)
    columns = [ens.output_names.index(name) for name in target.outputs]
    share = (time.perf_counter() - t0) / max(1, n_pts)
    rows, again = [], []
    for j, (point, values, inputs) in enumerate(batch):
        k = int(res.n_rows[j])
        out = res.y_grid[j, :k][:, columns]
        if res.status[j] not in (0, 2) or k < 1 or not np.all(np.isfinite(out)):
            again.append((point, values, inputs))
            continue
        terminated = res.status[j] == 2
        times = res.grid[:k].copy()
        if terminated:
            times[k - 1] = res.t_final[j]
        fired = {name for name, on in zip(ens.event_names, res.flags[j]) if on}
        flags = [name for name in target.flag_names if name in fired]  # the plain loop's order
        try:
            row = metrics.evaluate(Run(times, out, list(target.outputs), settings.stop_time, bool(terminated),
                                       flags), inputs)
            row.update(status="ok", reason="")
        except PointFailure as exc:  # a user metric that raised: as in the plain path
            row = {"status": "error", "reason": str(exc)}
        row.update(point=point, wall_time=share)
        rows.append(row)
    if again:
        rows += run_plain(again)
    order = {point: i for i, (point, _, _) in enumerate(batch)}
    return sorted(rows, key=lambda row: order[row["point"]])
