"""Where the batches run: a plain in-process loop, a LocalCluster of processes, or any Dask scheduler.

- workers=0: no Dask; the batches run one after another in this process (debugging, tests,
  the reference the Dask paths must equal bit for bit).
- workers=N (default: the machine's cores): a distributed.LocalCluster of N worker processes,
  one thread each (the FMU releases the GIL in fmi2DoStep, but one process per core also keeps
  Python's own work parallel); never more processes than points, and more than
  WORKERS_PER_CORE per core are refused (local_workers). The cluster's processes keep their
  temporary files in one directory of the sweep, removed when it ends (gyrowheel/scratch.py).
- scheduler='tcp://host:port': a running cluster (`dask scheduler`, `dask worker ADDRESS`); its
  workers need gyrowheel installed (they import gyrowheel.studies), not the FMU nor user files.
- client=distributed.Client: an existing client (Python API).
The FMU's bytes travel once, as a task's result; each task is one batch (gyrowheel.studies.batch).
Rows are handed to the writer as batches finish; Ctrl-C cancels what is left (and waits until the
scheduler has let go of it) and re-raises after the rows done so far are written. While Dask is
in use a Ctrl-C only asks for that stop, acted on between steps (gyrowheel.studies.interrupt): a
KeyboardInterrupt inside Dask's own blocking calls printed tracebacks from its IO loop.
"""
from __future__ import annotations

import contextlib
import math
import os
import shutil
import signal
import subprocess
import threading
import time
import uuid

from gyrowheel.arguments import check_memory, count
from gyrowheel.errors import SweepSpecError
from gyrowheel.studies.batch import run_batch
from gyrowheel.studies.interrupt import deferred_sigint
from gyrowheel.scratch import remove_stale, sweep_directory

MAX_BATCH = 500
# The workers' statistical profiler samples every thread's stack every 10 ms: ~4% of the CPU of
# 1 ms points (benchmarks/sweep_scaling.py). Off for our LocalCluster; for a cluster of your own,
# start the workers with DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False.
# The workers of our LocalCluster ignore SIGINT (see _children_ignore_sigint).
WORKER_PRELOAD = "gyrowheel.studies.worker_setup"
LOCAL_CONFIG = {"distributed.worker.profile.enabled": False, "distributed.worker.preload": [WORKER_PRELOAD]}
TASKS_PER_THREAD = 4
# worker processes per core at most in our LocalCluster: each is a Python process with its own
# memory and start-up (1000 of them on 2 cores were still starting after 120 s), and more
# processes than cores only share the cores. A cluster of your own: --scheduler.
WORKERS_PER_CORE = 4
LOOP_BATCH = 64  # points, the in-process loop's default batch (run_loop)
CONNECT_TIMEOUT = 20.0  # s, for a scheduler address to connect and answer Dask's handshake
# s, how long an address whose connections are refused (or fail otherwise at once) is tried again
# before the sweep gives up: a scheduler that is just starting gets this long to listen
REFUSED_WAIT = 2.0
POLL = 0.02  # s, the longest a Ctrl-C waits for the batch collector to see it
# a point's trajectory where it runs: its outputs in a float64 array (batch.run_point, or the
# ensemble's table of a batch), and one copy of them (the structured array metric functions get)
BYTES_PER_VALUE = 16


def check_size(plan, *, workers: int | None = None, scheduler: str | None = None, client=None,
               batch_size: int | None = None) -> None:
    """The memory rule (gyrowheel.arguments.check_memory) for the trajectories this machine holds
    at once: each point's outputs at every communication point (BYTES_PER_VALUE a value), for as
    many points as run here together: one in the in-process loop, one per worker of our
    LocalCluster, a whole batch on the ensemble path (its table of every point's grid). On a
    scheduler or client of your own the workers' machines are not known: one worker's share is
    checked against this machine's memory. Raises SweepSpecError naming --stop-time and
    --output-interval."""
    from gyrowheel.studies.ensemble_path import applies

    n, h = plan.settings.grid()
    rows, columns, total = n + 1, len(plan.target.outputs) + 1, max(1, len(plan.values))
    local = client is None and scheduler is None
    runs = (1 if workers == 0 else local_workers(workers, total)[0]) if local else 1
    points = 1
    if plan.settings.ensemble and applies(plan.target, plan.settings):
        points = batch_size or (LOOP_BATCH if local and workers == 0 else auto_batch_size(total, runs))
    at_once = min(runs * points, total)
    what = (f"--stop-time {plan.settings.stop_time:g} s with --output-interval {h:g} s: {count(rows)} communication "
            f"points of {columns} columns" + (f" for each of {at_once} points run at once" if at_once > 1 else ""))
    advice = "choose a shorter --stop-time or a longer --output-interval" + (
        ", or fewer --workers or a smaller --batch-size" if at_once > 1 else "")
    check_memory(rows * columns * at_once, BYTES_PER_VALUE, what, advice, argument=None, error=SweepSpecError)


def cores() -> int:
    """The cores this process may run on: its CPU affinity where the system reports one
    (os.sched_getaffinity: `taskset -c 0 gyrowheel sweep ...` gives 1, so a LocalCluster does
    not start more workers than it can run), else the machine's (os.cpu_count()); 1 if neither
    can say."""
    try:
        return len(os.sched_getaffinity(0)) or 1
    except (AttributeError, OSError):  # no affinity on this system (macOS, Windows)
        return os.cpu_count() or 1


def check_workers(workers: int | None) -> None:
    """Refuse a LocalCluster of more than WORKERS_PER_CORE processes per core (SweepSpecError
    naming --workers, the cores and the most allowed); None (one per core) and 0 (no Dask) pass."""
    most = WORKERS_PER_CORE * cores()
    if workers is not None and workers > most:
        raise SweepSpecError(f"--workers {workers}: more than {WORKERS_PER_CORE} worker processes per core "
                             f"({cores()} cores here: at most {most}); for more, start a Dask cluster and give "
                             f"--scheduler")


def local_workers(workers: int | None, n_points: int) -> tuple[int, str]:
    """The worker processes of our LocalCluster for `workers` (None: one per core; checked by
    check_workers) and a sweep of n_points, and why that many, in words: never more than the
    points, which leave any further process idle ('2 workers (one per point; --workers 3)')."""
    asked = workers or cores()
    n = max(1, min(asked, n_points))
    why = "one per core" if workers is None else ""
    if n < asked:
        why = "one per point" + (f"; --workers {workers}" if workers is not None else f"; {asked} cores")
    return n, f"{n} worker{'s' * (n != 1)}" + (f" ({why})" if why else "")


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
    if type(exc).__name__ == "KilledWorker":  # Dask gave up after allowed-failures + 1 deaths
        # Dask counts a death against every task waiting on the dying worker: an innocent batch
        # queued beside the crashing one can be given up too (docs/sweeps.md)
        reason = ("a worker process died on every try while this batch ran or waited on it (a crash in the unit "
                  "or a metric function, in this batch or one beside it?): KilledWorker")
    else:
        reason = f"task failed: {type(exc).__name__}: {exc}"
    return [{"point": p, "status": "error", "reason": reason, "wall_time": 0.0} for p, _, _ in batch]


def _payload(data):
    """The unit's bytes as a task of their own (see run_dask)."""
    return data


def run_loop(plan, writer, batch_size: int | None = None, progress: bool = False) -> None:
    """The plain in-process loop: the same batches, the same function, no Dask.

    Default batches of LOOP_BATCH points, not one batch of every point: rows reach the writer
    (the table on disk, the progress bar) as batches end, so one batch left a Ctrl-C with no row
    at all however long the sweep had run. 64 points: enough for the ensemble path (it advances
    a batch's points together, the CPU's lane count at a time: gyrowheel.taylor.lanes), and no
    slower than one batch (1200 points of the paper's moon scene: 8.1 s in batches of 50, 300 or
    1200 alike)."""
    tasks = plan.tasks(batch_size or LOOP_BATCH)
    payload = plan.target.payload()
    with _progress(len(plan.values), progress) as bar:
        for batch in tasks:
            rows = run_batch(plan.target, payload, plan.settings, plan.metrics, batch)
            writer.add(rows)
            bar.update(len(rows))


def run_dask(plan, writer, *, client, batch_size: int | None = None, progress: bool = False) -> None:
    """Submit one task per batch to `client`, collect rows as tasks finish (any order).

    A Ctrl-C (gyrowheel.studies.interrupt) is acted on between submissions and between batches
    collected: the tasks left are cancelled and KeyboardInterrupt raised, the rows so far with
    the writer.
    """
    with deferred_sigint() as interrupt:
        futures: dict = {}
        shipped = None
        try:
            nthreads = client.nthreads()  # {worker: threads}
            threads = sum(nthreads.values()) or 1
            size = batch_size or auto_batch_size(len(plan.values), threads)
            payload = plan.target.payload()
            tag = uuid.uuid4().hex[:8]
            # The bytes travel once, as a task's result, not scattered: if every worker holding
            # them dies (killed, or a unit that crashes its process), the scheduler computes them
            # again; scattered data would be lost and every batch still waiting cancelled with it.
            if payload is not None:
                shipped = client.submit(_payload, payload, key=f"gyrowheel-sweep-{tag}-payload", pure=False)
            if shipped is not None and len(nthreads) > 1:  # more than one worker process
                # ... and are copied to every worker before the batches go out: a batch prefers a
                # worker holding its input, so with the bytes on one worker the others sat idle
                # (1 -> 2 workers gave 1.0-1.6x instead of 1.9x, benchmarks/sweep_scaling.py).
                interrupt.check()
                client.replicate([shipped])
            for i, batch in enumerate(plan.tasks(size)):
                interrupt.check()
                futures[client.submit(run_batch, plan.target, shipped, plan.settings, plan.metrics, batch,
                                      key=f"gyrowheel-sweep-{tag}-{i}", pure=False)] = batch
            _collect(futures, writer, interrupt, len(plan.values), progress)
        except BaseException:
            _cancel(client, [*futures, *([shipped] if shipped is not None else [])])
            raise


def _collect(futures: dict, writer, interrupt, total: int, progress: bool) -> None:
    """Hand each batch's rows to `writer` as it finishes; KeyboardInterrupt between batches on a Ctrl-C."""
    from distributed import as_completed

    done = as_completed(futures)
    with _progress(total, progress) as bar:
        while not done.is_empty():
            interrupt.check()
            if not done.has_ready():
                interrupt.wait(POLL)
                continue
            future = next(done)
            batch = futures[future]
            try:
                rows = future.result()
            except Exception as exc:  # a worker died, a batch could not be unpickled...
                rows = _failed_rows(batch, exc)
            writer.add(rows)
            bar.update(len(rows))
            future.release()


def _still_known(keys, dask_scheduler=None) -> int:
    """On the scheduler: how many of `keys` it still has."""
    return sum(key in dask_scheduler.tasks for key in keys)


def _cancel(client, futures, timeout: float = 5.0) -> None:
    """Cancel `futures` (the payload too) and wait until the scheduler has forgotten them.

    Client.cancel only sends a message: a client that disconnects right after leaves the
    scheduler reporting results (and recomputing lost ones, the payload) to a closed connection,
    with tracebacks on our stderr for a LocalCluster (a Ctrl-C that is not clean).
    """
    keys = [f.key for f in futures]
    deadline = time.monotonic() + timeout
    try:
        client.cancel(futures)
        while client.run_on_scheduler(_still_known, keys) and time.monotonic() < deadline:
            time.sleep(0.02)
    except Exception:  # noqa: BLE001 - a scheduler gone or refusing to run functions: nothing to wait
        pass  # for, and the error that brought us here is the one to report


def probe_scheduler(address: str, timeout: float | None = None) -> None:
    """Raise ConnectionError unless a Dask scheduler at `address` completes Dask's handshake in time
    (SweepSpecError for an address that is none).

    distributed.Client bounds the TCP connection by its timeout but not the handshake after it: an
    address where something accepts and stays silent would hang it forever, and one that answers
    otherwise (a web server, the dashboard's port) makes it read a garbage frame length.
    """
    import asyncio

    from distributed.comm import connect

    timeout = CONNECT_TIMEOUT if timeout is None else timeout
    refused = _refusing(address, REFUSED_WAIT)
    if refused is not None:
        raise ConnectionError(f"no Dask scheduler at {address}: {refused} (tried for {REFUSED_WAIT:g} s)")
    outcome: dict = {}

    async def handshake():
        comm = await asyncio.wait_for(connect(address, timeout=timeout), timeout)
        await comm.close()

    def run():  # in a thread of its own: the caller may be inside an event loop (Jupyter)
        try:
            asyncio.run(handshake())
        except BaseException as exc:  # noqa: BLE001 - any failure means: no scheduler there
            outcome["error"] = exc

    thread = threading.Thread(target=run, name="gyrowheel-probe-scheduler", daemon=True)
    thread.start()
    thread.join(timeout + 5)
    if thread.is_alive() or isinstance(outcome.get("error"), (asyncio.TimeoutError, TimeoutError)):
        raise ConnectionError(f"no Dask scheduler answers at {address} within {timeout:g} s")
    if "error" in outcome:
        exc = outcome["error"]
        if isinstance(exc, ValueError):  # a malformed address
            raise SweepSpecError(f"--scheduler {address!r}: {exc}") from None
        raise ConnectionError(f"no Dask scheduler at {address}: {type(exc).__name__}: {exc}")


def _refusing(address: str, wait: float) -> str | None:
    """Why a tcp:// or tls:// address cannot be connected to at all ('connection refused': nothing
    listens on the port; an unknown host...), after trying again for `wait` s; None when a TCP
    connection is made, when the attempt is still pending after `wait` s (a silent host: the
    handshake's timeout decides) or for another kind of address.

    distributed's connect retries a refused connection until its timeout (20 s here, 30 s by
    default: distributed.comm.timeouts.connect) although nothing will answer there."""
    import socket

    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address)
        if scheme not in ("tcp", "tls"):
            return None
        host, port = parse_host_port(location)
    except ValueError:  # a malformed address: the handshake says what is wrong with it
        return None
    deadline = time.monotonic() + wait
    while True:
        try:
            with socket.create_connection((host, port), timeout=wait):
                return None
        except (socket.timeout, TimeoutError):
            return None
        except OSError as exc:
            reason = exc.strerror or str(exc) or type(exc).__name__
            if time.monotonic() >= deadline:
                return reason[:1].lower() + reason[1:]
            time.sleep(min(0.1, max(0.0, deadline - time.monotonic())))


class _Startup:
    interrupted = False


@contextlib.contextmanager
def _children_ignore_sigint():
    """Start worker processes that never see SIGINT, without losing a Ctrl-C meant for the sweep.

    Ctrl-C in a terminal reaches the whole process group; the workers must not die mid-batch with
    tracebacks of their own, the sweep must stop here, cleanly. SIGINT is ignored (SIG_IGN) while
    the cluster starts: an ignored signal stays ignored through exec and Python keeps it so, so
    the workers started meanwhile ignore it from their first instruction (a mask would not do:
    distributed starts them from threads that do not inherit ours). Workers the nanny restarts
    later ignore it from their preload on (WORKER_PRELOAD). An ignored Ctrl-C would be lost, so a
    sentinel child (`sleep`) with SIGINT at its default waits in our process group meanwhile: if
    it died of SIGINT, a Ctrl-C came, reported as `interrupted` when the block ends for the
    caller to stop once the cluster can be closed."""
    startup = _Startup()
    if threading.current_thread() is not threading.main_thread():
        yield startup
        return
    sentinel = _sentinel()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield startup
    finally:
        if sentinel is not None:
            time.sleep(0.01)  # a signal sent just now has reached the sentinel too
            startup.interrupted = sentinel.poll() == -signal.SIGINT
            sentinel.kill()
            sentinel.wait()
        signal.signal(signal.SIGINT, previous)


def _sentinel():
    """A `sleep` child in this process group with SIGINT at its default (None if none can start)."""
    sleep = shutil.which("sleep")
    if sleep is None or signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        return None  # no sleep, or SIGINT already ignored (nohup, a background job): nothing to see
    try:
        return subprocess.Popen([sleep, "3600"], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
    except OSError:
        return None


def execute(plan, writer, *, workers: int | None = None, scheduler: str | None = None, client=None,
            batch_size: int | None = None, progress: bool = False) -> None:
    """Run every point of `plan` and hand the rows to `writer` (see the module docstring)."""
    if client is None and scheduler is None and workers == 0:
        return run_loop(plan, writer, batch_size, progress)
    if client is not None:
        return run_dask(plan, writer, client=client, batch_size=batch_size, progress=progress)
    from distributed import Client

    if scheduler is not None:
        try:
            probe_scheduler(scheduler)  # a Ctrl-C here is plain: no client, no IO loop yet
            with deferred_sigint() as interrupt, Client(scheduler, timeout=f"{CONNECT_TIMEOUT}s") as c:
                interrupt.check()  # a Ctrl-C while the client connected
                return run_dask(plan, writer, client=c, batch_size=batch_size, progress=progress)
        finally:  # workers of this machine that were killed (gyrowheel/scratch.py)
            remove_stale()
    with sweep_directory() as scratch:
        return _run_local_cluster(plan, writer, local_workers(workers, len(plan.values))[0], scratch, batch_size,
                                  progress)


def _run_local_cluster(plan, writer, n: int, scratch, batch_size: int | None, progress: bool) -> None:
    """The sweep on a LocalCluster of n processes whose temporary files (TMPDIR, Dask's
    local_directory) all go beneath `scratch`, a directory the caller removes afterwards."""
    import dask
    from distributed import Client, LocalCluster

    with deferred_sigint() as interrupt:
        with dask.config.set({**LOCAL_CONFIG, "temporary-directory": str(scratch)}), \
                _children_ignore_sigint() as startup:  # (the scheduler's scratch space too)
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address=":0", local_directory=str(scratch),
                                   env={"TMPDIR": str(scratch)})
        if startup.interrupted:
            interrupt.request()
        # the cluster closes before the client: its scheduler, told of workers going or of a last
        # result, still finds the client there to tell (else it logs CommClosedError tracebacks)
        with cluster, Client(cluster) as c:
            try:
                interrupt.check()  # a Ctrl-C while the cluster started or the client connected
                return run_dask(plan, writer, client=c, batch_size=batch_size, progress=progress)
            except KeyboardInterrupt:
                _close_workers(cluster)
                raise


def _close_workers(cluster, timeout: float = 10.0) -> None:
    """Close the workers before the scheduler: closing both at once (the cluster's close), a
    worker's heartbeat could still be under way to the closed scheduler and print a traceback."""
    cluster.scale(0)
    deadline = time.monotonic() + timeout
    while cluster.workers and time.monotonic() < deadline:
        time.sleep(0.05)
