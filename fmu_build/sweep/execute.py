"""Where the batches run: a plain in-process loop, a LocalCluster of processes, or any Dask scheduler.

- workers=0: no Dask; the batches run one after another in this process (debugging, tests,
  the reference the Dask paths must equal bit for bit).
- workers=N (default: the machine's cores): a distributed.LocalCluster of N worker processes,
  one thread each (the FMU releases the GIL in fmi2DoStep, but one process per core also keeps
  Python's own work parallel).
- scheduler='tcp://host:port': a running cluster (`dask scheduler`, `dask worker ADDRESS`); its
  workers need gyrowheel installed (they import fmu_build.sweep), not the FMU nor user files.
- client=distributed.Client: an existing client (Python API).
The FMU's bytes are scattered to every worker once; each task is one batch (fmu_build.sweep.batch).
Rows are handed to the writer as batches finish; Ctrl-C cancels what is left and re-raises after
the rows done so far are written.
"""
from __future__ import annotations

import contextlib
import math
import os
import signal
import threading
import uuid

from fmu_build.sweep.batch import run_batch

MAX_BATCH = 500
# The workers' statistical profiler samples every thread's stack every 10 ms: ~4% of the CPU of
# 1 ms points (benchmarks/sweep_scaling.py). Off for our LocalCluster; for a cluster of your own,
# start the workers with DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False.
LOCAL_CONFIG = {"distributed.worker.profile.enabled": False}
TASKS_PER_THREAD = 4


def auto_batch_size(n_points: int, n_threads: int) -> int:
    """About TASKS_PER_THREAD tasks per worker thread (load balance), at most MAX_BATCH points per task.

    The scaling model in docs/sweeps.md says why: a task costs the scheduler a few ms, so a batch
    should run for >= ~0.1 s (100 points of 1 ms); more tasks than threads lets fast workers take
    more of them.
    """
    return max(1, min(MAX_BATCH, math.ceil(n_points / (TASKS_PER_THREAD * max(1, n_threads)))))


def _progress(total: int, enabled: bool):
    """tqdm on stderr when asked for and stderr is a terminal (no bar spam in logs and CI)."""
    import sys

    from tqdm import tqdm
    return tqdm(total=total, unit="pt", disable=not (enabled and sys.stderr.isatty()), smoothing=0.1,
                dynamic_ncols=True)


def _failed_rows(batch, exc) -> list[dict]:
    reason = f"task failed: {type(exc).__name__}: {exc}"
    return [{"point": p, "status": "error", "reason": reason, "wall_time": 0.0} for p, _, _ in batch]


def run_loop(plan, writer, batch_size: int | None = None, progress: bool = False) -> None:
    """The plain in-process loop: the same batches, the same function, no Dask."""
    tasks = plan.tasks(batch_size or len(plan.values) or 1)
    payload = plan.target.payload()
    with _progress(len(plan.values), progress) as bar:
        for batch in tasks:
            rows = run_batch(plan.target, payload, plan.settings, plan.metrics, batch)
            writer.add(rows)
            bar.update(len(rows))


def run_dask(plan, writer, *, client, batch_size: int | None = None, progress: bool = False) -> None:
    """Submit one task per batch to `client`, collect rows as tasks finish (any order)."""
    from distributed import as_completed

    threads = sum(client.nthreads().values()) or 1
    size = batch_size or auto_batch_size(len(plan.values), threads)
    tasks = plan.tasks(size)
    payload = plan.target.payload()
    shipped = client.scatter(payload, broadcast=True, hash=False) if payload is not None else None
    tag = uuid.uuid4().hex[:8]
    futures = {client.submit(run_batch, plan.target, shipped, plan.settings, plan.metrics, batch,
                             key=f"gyrowheel-sweep-{tag}-{i}", pure=False): batch
               for i, batch in enumerate(tasks)}
    try:
        with _progress(len(plan.values), progress) as bar:
            for future in as_completed(futures):
                batch = futures[future]
                try:
                    rows = future.result()
                except Exception as exc:  # a worker died, a batch could not be unpickled...
                    rows = _failed_rows(batch, exc)
                writer.add(rows)
                bar.update(len(rows))
                future.release()
    except BaseException:
        client.cancel(list(futures))
        raise


@contextlib.contextmanager
def _children_ignore_sigint():
    """Start worker processes with SIGINT ignored (inherited through exec; Python keeps an ignored
    SIGINT ignored), so that Ctrl-C in a terminal, which reaches the whole process group, stops the
    sweep here, cleanly, instead of killing the workers mid-batch with tracebacks of their own."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def execute(plan, writer, *, workers: int | None = None, scheduler: str | None = None, client=None,
            batch_size: int | None = None, progress: bool = False) -> None:
    """Run every point of `plan` and hand the rows to `writer` (see the module docstring)."""
    if client is None and scheduler is None and workers == 0:
        return run_loop(plan, writer, batch_size, progress)
    if client is not None:
        return run_dask(plan, writer, client=client, batch_size=batch_size, progress=progress)
    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        with Client(scheduler, timeout="20s") as c:
            return run_dask(plan, writer, client=c, batch_size=batch_size, progress=progress)
    n = workers or os.cpu_count() or 1
    with dask.config.set(LOCAL_CONFIG), _children_ignore_sigint():
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=":0")
    with cluster, Client(cluster) as c:
        return run_dask(plan, writer, client=c, batch_size=batch_size, progress=progress)
