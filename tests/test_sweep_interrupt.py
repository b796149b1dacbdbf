"""fmu_build.sweep.interrupt: Ctrl-C as a stop request while Dask is at work (no Dask needed here)."""
from __future__ import annotations

import os
import signal
import time

import pytest

from fmu_build.sweep.interrupt import deferred_sigint


@pytest.fixture
def default_sigint():
    """Python's own SIGINT handler for the test, as in a terminal (make test may run with it ignored)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def _ctrl_c() -> None:
    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(0.05)  # the handler runs here (the main thread)


def test_ctrl_c_is_recorded_not_raised_and_acted_on_at_check(default_sigint):
    with pytest.raises(KeyboardInterrupt), deferred_sigint() as interrupt:
        _ctrl_c()  # nothing raised here, in the middle of whatever ran
        assert interrupt.requested
        with deferred_sigint() as inner:  # a nested block shares the request
            assert inner is interrupt
        with pytest.raises(KeyboardInterrupt):
            interrupt.check()
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_request_never_checked_raises_when_the_block_ends(default_sigint):
    with pytest.raises(KeyboardInterrupt):
        with deferred_sigint() as interrupt:
            _ctrl_c()
            assert interrupt.wait(1.0)
    with deferred_sigint() as interrupt:  # and none came: nothing raised
        assert not interrupt.wait(0.0)


def test_a_programs_own_handler_is_left_alone():
    seen = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: seen.append(signum))
    try:
        with deferred_sigint() as interrupt:
            _ctrl_c()
            assert seen == [signal.SIGINT] and not interrupt.requested
            interrupt.request()  # a Ctrl-C that came another way (LocalCluster start-up)
            assert interrupt.requested
    except KeyboardInterrupt:
        pass
    else:
        pytest.fail("a request not acted on in the block must raise KeyboardInterrupt at its end")
    finally:
        handler = signal.signal(signal.SIGINT, previous)
    assert handler is not signal.default_int_handler and handler is not signal.SIG_IGN
