"""The FMU's error messages, per instance, through fmpy's one process-wide logger.

fmpy (0.3.32) proxies ONE Python logger per process (fmpy.logging.addLoggerProxy formats the
FMU's variadic message and calls the last callback registered). So every instance registers the
same process-lived dispatcher and tells itself apart by its componentEnvironment (FMI 2.0.4
section 2.1.5): its messages of status fmi2Error and fmi2Fatal (which the FMU always logs,
docs/fmi.md) land in its own list. Used by gyrowheel's master (cosim/master.py) and the sweeps
(studies/target.py).
"""
from __future__ import annotations

import threading
from ctypes import byref

_MESSAGES: dict[int, list] = {}
_LOGGER = None
_NEXT_ID = 0
_LOCK = threading.Lock()


def _dispatch_log(env, instance, status, category, message):
    if status >= 3:  # fmi2Error, fmi2Fatal
        messages = _MESSAGES.get(env or 0)
        if messages is not None:
            messages.append((message or b"").decode(errors="replace"))


def logging_callbacks(messages: list[str]):
    """(fmi2CallbackFunctions, id): fmpy's allocator and a logger that appends the FMU's error
    messages to `messages`. Keep the structure alive as long as the instance; call
    forget_messages(id) when the instance is freed."""
    from fmpy import calloc, free
    from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions,
                           fmi2CallbackLoggerTYPE)
    from fmpy.logging import addLoggerProxy

    global _LOGGER, _NEXT_ID
    with _LOCK:
        if _LOGGER is None:
            _LOGGER = fmi2CallbackLoggerTYPE(_dispatch_log)
        _NEXT_ID += 1
        ident = _NEXT_ID
        _MESSAGES[ident] = messages
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = _LOGGER
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    callbacks.componentEnvironment = ident
    addLoggerProxy(byref(callbacks))
    return callbacks, ident


def forget_messages(ident: int) -> None:
    """The instance is freed: its messages are no longer collected."""
    _MESSAGES.pop(ident, None)


def fmi3_logger(messages: list[str]):
    """An fmi3LogMessageCallback (FMI 3.0.2 section 2.3.1) for one instance: it appends the
    messages of status fmi3Error and fmi3Fatal to `messages`. FMI 3.0 hands the callback each
    instance's own function and an already formatted message, so no dispatcher is needed; fmpy
    keeps the C callback alive on its FMU3Slave (slave.logMessage)."""
    def log(env, status, category, message):
        if status >= 3:  # fmi3Error, fmi3Fatal
            messages.append((message or b"").decode(errors="replace"))
    return log
