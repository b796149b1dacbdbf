"""Start a child as a terminal would: SIGINT at its default, so Ctrl-C tests mean something.

A shell starts background jobs with SIGINT ignored (POSIX, no job control; CI runners often run
`make test` that way), Python then never installs its KeyboardInterrupt handler, and every child
inherits the ignored signal through exec: a Ctrl-C test would see a sweep that cannot be
interrupted and run to its end. These options give the child a terminal's disposition.
"""
import signal


def _sigint_default() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


# for subprocess.Popen: its own process group (a terminal's Ctrl-C reaches the whole group),
# SIGINT at its default
AS_FROM_A_TERMINAL = {"start_new_session": True, "preexec_fn": _sigint_default}
