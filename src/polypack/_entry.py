"""Console entry point (``polypack``, ``python -m polypack``): a Ctrl-C while the CLI's
modules are still being imported exits 130 with one line, like one during a command."""

from __future__ import annotations

import os
import sys


def _exit_130():
    # os._exit: CPython kills itself with SIGINT at exit once a KeyboardInterrupt passed
    # through some C-level code (even if it was caught later); the exit code must be 130
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:  # noqa: BLE001 - closed or broken stream
            pass
    os._exit(130)


def _restore_sigint():
    """Give Ctrl-C / ``kill -INT`` back to a command started in the background.

    A POSIX shell without job control (a script, ``cmd &`` in a non-interactive shell)
    starts background commands with SIGINT ignored, and Python then keeps it ignored:
    ``kill -INT`` would not stop a long ``polypack run`` at a safe point.  The CLI
    restores Python's default handler (KeyboardInterrupt), so SIGINT stops every
    command at its next safe point however it was started.  SIGTERM keeps its default
    action (the process ends at once; outputs are written atomically, so nothing
    interrupted is recorded as complete).
    """
    import signal

    try:
        if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
            signal.signal(signal.SIGINT, signal.default_int_handler)
    except (ValueError, OSError, AttributeError):  # not the main thread, or no signals here
        pass


def main(argv=None):
    _restore_sigint()
    try:
        from .cli import main as cli_main
    except KeyboardInterrupt:
        sys.stderr.write("interrupted: nothing was saved\n")
        _exit_130()
    try:
        return cli_main(argv)
    except SystemExit as exc:
        if exc.code == 130:
            _exit_130()
        raise
