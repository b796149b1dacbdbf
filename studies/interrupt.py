"""Ctrl-C while Dask is at work: a request to stop, honoured where the sweep can stop cleanly.

Python raises KeyboardInterrupt in the main thread at whatever bytecode it is running. While a
distributed.Client is in use that is usually inside one of Dask's blocking calls
(distributed.utils.sync: Future.result, Client(...), replicate, close), whose coroutine runs
on the client's IO-loop thread and goes on without the caller. distributed's own answer, a
`cancel` callback sync adds to the loop on KeyboardInterrupt, reads the coroutine's asyncio
future before the loop may have created it: when the loop thread is slow to get there (a loaded
machine) the callback raises NameError ("cannot access free variable 'future'"), which tornado
logs with a traceback (ioloop.py, _run_callback) on the user's terminal. Other landings leave a
half-done connect, replicate or close behind.

So while the sweep talks to Dask, SIGINT only sets a flag (`Interrupt`); the sweep looks at it
between its own steps (after the client is up, between submissions, between batches collected,
after each write of the table) and raises KeyboardInterrupt there, outside any Dask call, then
cancels and closes in order. Every Dask call the main thread makes meanwhile is bounded by a
timeout, so a stop is never put off for long. Further Ctrl-Cs while the sweep winds down ask for
the same stop. Only the default handler is replaced (a program's own SIGINT handler, or an
ignored SIGINT, is left alone), only in the main thread, and it is restored afterwards.
"""
from __future__ import annotations

import contextlib
import signal
import threading


class Interrupt:
    """A Ctrl-C received but not yet acted on (see the module docstring)."""

    def __init__(self) -> None:
        self._event = threading.Event()

    def handler(self, signum, frame) -> None:  # the SIGINT handler: record, raise nothing
        self._event.set()

    def request(self) -> None:
        """Ask for the stop as a Ctrl-C would (one that came while SIGINT was ignored, say)."""
        self._event.set()

    @property
    def requested(self) -> bool:
        return self._event.is_set()

    def check(self) -> None:
        """Raise KeyboardInterrupt if a Ctrl-C came: call it only where stopping is clean."""
        if self._event.is_set():
            raise KeyboardInterrupt

    def wait(self, timeout: float) -> bool:
        """Sleep up to `timeout` s, less if a Ctrl-C comes; True if one came."""
        return self._event.wait(timeout)


@contextlib.contextmanager
def deferred_sigint():
    """Within the block SIGINT sets the yielded Interrupt instead of raising (see module docstring).

    Nested blocks share the outer block's Interrupt. Outside the main thread, or when SIGINT is
    not at Python's default handler, SIGINT is left as it is and the Interrupt only reports
    requests made with Interrupt.request. A request the block never acted on (a Ctrl-C during the
    last steps) raises KeyboardInterrupt once the block is over: the user asked to stop.
    """
    current = signal.getsignal(signal.SIGINT) if threading.current_thread() is threading.main_thread() else None
    owner = getattr(current, "__self__", None)
    if isinstance(owner, Interrupt):  # an outer block has it already
        yield owner
        return
    interrupt = Interrupt()
    if current is signal.default_int_handler:
        signal.signal(signal.SIGINT, interrupt.handler)
    try:
        yield interrupt
    finally:
        if current is signal.default_int_handler:
            signal.signal(signal.SIGINT, signal.default_int_handler)
    interrupt.check()
