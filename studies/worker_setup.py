"""Preload of the workers of `gyrowheel sweep`'s own LocalCluster (execute.LOCAL_CONFIG).

Ctrl-C in a terminal reaches the whole process group, the worker processes included: they
ignore it, so that the sweep stops in the command, cleanly (exit 130, the table on disk), and
not with a traceback from each worker. The workers started with the cluster inherit an ignored
SIGINT already; this covers the ones the nanny starts later, after a worker died.

A worker that closes while its heartbeat to the scheduler is on the wire logs that heartbeat's
failure with a traceback: distributed's Worker.close stops the heartbeat's periodic callback but
not a call already under way, then closes its connection pool under it (CommClosedError, "Stream
is closed"; dask/distributed issues 7192, 9032). When the sweep closes its cluster that is noise,
seen in about one Ctrl-C in a few hundred; the filter drops exactly that record while the worker is
closing, and keeps it (a real loss of the scheduler) while the worker runs.

A worker closed while it runs a batch (the sweep's Ctrl-C: cancel, then close the workers)
logs "Async instruction for <Task ...> ended with CancelledError" at WARNING for every batch under
way (distributed.worker_state_machine: "This should exclusively happen in Worker.close()"), two
lines of Dask's internals on the user's terminal after every Ctrl-C; the second filter drops
exactly that record while the worker is closing.
"""
from __future__ import annotations

import logging
import signal
import threading

HEARTBEAT_FAILURE = "Failed to communicate with scheduler during heartbeat."
CANCELLED = ("Async instruction for ", " ended with CancelledError")  # distributed.worker_state_machine
CLOSING = frozenset({"closing", "closed", "closing_gracefully", "failed"})


class HeartbeatWhileClosing(logging.Filter):
    """Drops the heartbeat-failure record of `worker` once that worker is closing (see above)."""

    def __init__(self, worker) -> None:
        super().__init__()
        self.worker = worker

    def filter(self, record: logging.LogRecord) -> bool:
        status = getattr(getattr(self.worker, "status", None), "name", None)
        return not (record.getMessage() == HEARTBEAT_FAILURE and status in CLOSING)


class CancelledWhileClosing(HeartbeatWhileClosing):
    """Drops the state machine's "... ended with CancelledError" record once `worker` is closing."""

    def filter(self, record: logging.LogRecord) -> bool:
        status = getattr(getattr(self.worker, "status", None), "name", None)
        message = record.getMessage()
        return not (status in CLOSING and message.startswith(CANCELLED[0]) and message.endswith(CANCELLED[1]))


def dask_setup(worker) -> None:
    """Called by distributed in the worker process when the worker starts."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    logging.getLogger("distributed.worker").addFilter(HeartbeatWhileClosing(worker))
    logging.getLogger("distributed.worker.state_machine").addFilter(CancelledWhileClosing(worker))
