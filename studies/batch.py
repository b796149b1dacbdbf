"""One task's work: a batch of points in ONE instance (instantiate once, then reset/set/step).

This is the only code that runs on the workers, and the plain in-process loop calls the very
same function, so a point's metrics do not depend on where or in which batch it ran: every point
starts from fmi2Reset, gets the same values in the same order and the same communication grid
t_i = t0 + i h, steps t_(i+1) - t_i, the last one landing on the stop time (as fmpy.simulate_fmu
steps, so a point gives what `gyrowheel simulate` gives, bit for bit).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from gyrowheel.studies.metrics import MetricSet, Run
from gyrowheel.studies.target import PointFailure


@dataclass(frozen=True)
class Settings:
    """The experiment shared by all points: times [s] and the values every point sets first."""

    stop_time: float
    output_interval: float
    start_time: float = 0.0
    fixed: dict = field(default_factory=dict)  # FMU name -> value, set before each point's own values
    ensemble: bool = True  # batches take the ensemble path where it applies (sweep/ensemble_path.py)

    def grid(self) -> tuple[int, float]:
        """(number of communication steps, step size)."""
        span = self.stop_time - self.start_time
        n = max(1, math.ceil(span / self.output_interval - 1e-9))
        return n, self.output_interval


def run_point(instance, values: dict, settings: Settings, metrics: MetricSet, inputs: dict) -> dict:
    """Run one point; returns its metric columns. Raises PointFailure with the unit's reason."""
    n, h = settings.grid()
    t0 = settings.start_time
    instance.start({**settings.fixed, **values}, t0)
    names = instance.output_names
    out = np.empty((n + 1, len(names)))
    times = np.empty(n + 1)
    times[0] = t0
    instance.read(out[0])
    k, terminated = n + 1, False
    t = t0
    for i in range(n):
        t_next = settings.stop_time if i == n - 1 else t0 + (i + 1) * h  # fmpy's grid: no drift
        event_time = instance.step(t, t_next - t)
        instance.read(out[i + 1])
        if event_time is not None:
            times[i + 1], k, terminated = event_time, i + 2, True
            break
        times[i + 1] = t = t_next
    if not np.all(np.isfinite(out[:k])):  # the FMU promises never to output NaN; hold it to that
        raise PointFailure("non-finite output")
    finals = instance.finals(metrics.discrete) if metrics.discrete else {}
    run = Run(times[:k], out[:k], names, settings.stop_time, terminated, instance.flags(), finals)
    return metrics.evaluate(run, inputs)


def run_batch(target, payload, settings: Settings, metrics: MetricSet, batch: list,
              ensemble: bool = True) -> list[dict]:
    """Run `batch` = [(point number, FMU values, inputs as given), ...] in one instance, or through
    the ensemble path when the unit's solver is taylor (gyrowheel.studies.ensemble_path; ensemble
    and settings.ensemble allow it).

    Returns one row per point: {'point', metric columns..., 'status' ('ok' | 'error'), 'reason',
    'wall_time' [s]}. A point that fails is a row with its reason; the batch goes on.
    """
    if ensemble and settings.ensemble:
        from gyrowheel.studies.ensemble_path import run_batch_ensemble
        rows = run_batch_ensemble(target, payload, settings, metrics, batch,
                                  lambda points: run_batch(target, payload, settings, metrics, points, False))
        if rows is not None:
            return rows
    rows = []
    try:
        instance = target.open(payload)
    except Exception as exc:
        reason = f"cannot instantiate the unit: {type(exc).__name__}: {exc}"
        return [{"point": p, "status": "error", "reason": reason, "wall_time": 0.0} for p, _, _ in batch]
    try:
        for point, values, inputs in batch:
            t0 = time.perf_counter()
            try:
                row = run_point(instance, values, settings, metrics, inputs)
                row.update(status="ok", reason="")
            except PointFailure as exc:
                row = {"status": "error", "reason": str(exc)}
            row["point"] = point
            row["wall_time"] = time.perf_counter() - t0
            rows.append(row)
    finally:
        instance.close()
    return rows
