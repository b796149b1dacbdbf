"""Preload of the workers of `gyrowheel sweep`'s own LocalCluster (execute.LOCAL_CONFIG).

Ctrl-C in a terminal reaches the whole process group, the worker processes included: they
ignore it, so that the sweep stops in the command, cleanly (exit 130, the table on disk), and
not with a traceback from each worker. The workers started with the cluster inherit an ignored
SIGINT already; this covers the ones the nanny starts later, after a worker died.
"""
from __future__ import annotations

import signal
import threading


def dask_setup(worker) -> None:
    """Called by distributed in the worker process's main thread when the worker starts."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
